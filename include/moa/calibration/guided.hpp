// Guided calibration: no reference sensor, three hand-made motions.
//
// The user pushes the robot a known distance d along its x axis (and
// optionally along y) without turning it, then spins it K whole turns about
// the point that is to be the robot's centre. A sensor's count total over a
// motion is the integral of the measurement model,
//   C_i = M_i  integral v dt  +  q_i  integral omega dt,
// so, with the body-frame displacement of a push along x being (d, 0) and
// the spin's net rotation 2 pi K (spin about the robot-frame point c: v =
// -omega J c):
//   C_i^x = d M_i e_x,   C_i^y = d M_i e_y,   C_i^s = 2 pi K M_i J (p_i - c).
// Hence M_i = [C^x C^y] / d, split into yaw, per-axis scale and mirroring
// (least squares on the model's form: Eigen's Levenberg-Marquardt on the
// four entries); without push-y only M_i e_x is known and the scale is taken
// isotropic (sx = sy); then f = 1 with yaw and f = -1 with -yaw fit alike,
// and the mirroring is the one that puts the sensor clearly nearer its
// nominal place after the spin (else the nominal one). Then
//   p_i = -J M_i^-1 C_i^s / (2 pi K)   (+ c: the spin centre, which the data cannot see).
//
// What each procedural error costs (first order; docs/calibration.md):
//   spin about c instead of the centre   every position shifted by -c
//   distance off by e d                  scales off by e, positions by -e p
//   spin angle off by a                  positions scaled by 1 + a / (2 pi K)
//   a push turning by b                  M_i e_x off by b q_i / d: yaw and scale
//                                        errors of order b |p_i| / d
//   no push-y, sy / sx = 1 + a           yaw off by up to a / 2, sy off by a
// These, with the tolerances below, give the reported 1-sigma: each source
// is propagated by re-solving with the input perturbed by +-1 sd.
//
// Directions: a push done backwards or a clockwise spin is detected
// against the nominal geometry (the sign that puts the sensors nearer their
// nominal places) and reported.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <variant>
#include <vector>

#include "moa/calibration/exact.hpp"
#include "moa/core/options_check.hpp"

namespace moa {

struct GuidedInput {
  std::vector<Eigen::Vector2d> push_x;                 ///< count totals per sensor
  std::optional<std::vector<Eigen::Vector2d>> push_y;  ///< count totals per sensor
  std::vector<Eigen::Vector2d> spin;                   ///< count totals per sensor
  double distance = 1.0;                               ///< m, each push
  double turns = 1.0;                                  ///< whole turns of the spin
};

/// One standard deviation of each procedural error.
struct GuidedTolerances {
  double distance_sd = 0.002;   ///< m, of the measured push distance
  double turn_sd = 0.0087;      ///< rad, of the spin's total angle (0.5 deg)
  double centre_sd = 0.001;     ///< m, per axis, of the spin centre
  double heading_sd = 0.0044;   ///< rad, rotation of the robot during a push (0.25 deg)
  double anisotropy_sd = 0.02;  ///< without push-y: of sy / sx - 1 (assumed 0)
  /// nullopt when usable (every sd positive and finite), else the first
  /// field out of its bounds (core/options_check.hpp).
  OptionCheck validate() const;
};

struct GuidedCalibration {
  std::vector<SensorCalibration> sensors;  ///< residual_rms unused (see push_misfit)
  SensorArray calibrated;
  Eigen::MatrixXd covariance;       ///< 5N x 5N, from the tolerances
  std::vector<double> push_misfit;  ///< per sensor, m: RMS misfit of the push totals
  bool isotropic_scale = false;     ///< push-y absent
  bool push_x_reversed = false;
  bool push_y_reversed = false;
  bool spin_clockwise = false;
  /// Mean calibrated position minus mean nominal position (m): a spin about
  /// another point than the intended centre shows here.
  Eigen::Vector2d centroid_shift{0.0, 0.0};
};

std::variant<GuidedCalibration, CalibrationError> calibrate_guided(
    const SensorArray& nominal, const GuidedInput& input, const GuidedTolerances& tolerances = {});

}  // namespace moa
