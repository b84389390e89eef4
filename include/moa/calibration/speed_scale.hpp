// Speed-dependent resolution from a reference (docs/calibration.md, "Speed
// scale"): each sensor's ratio of counted to true displacement as a
// function of its ground speed, at knots s_0 < ... < s_{K-1} (m/s), the
// table core/speed_scale.hpp holds.
//
// Per reference window w (a CalibrationSample: counts over dt and the
// reference twist) and sensor i at its current mount:
//   d_true = A_i z_w             z_w = reference twist * dt (m, m, rad): the
//                                sensor point's true displacement (m, robot frame)
//   d_cnt  = G_i^-1 c_iw         the displacement the counts say (m, robot frame)
//   s_w    = |d_true| / dt       the point's true ground speed (m/s)
//   u      = d_true / |d_true|
// and the model d_cnt = ratio(s_w) d_true, along the motion:
//   y_w = u . d_cnt = sum_k r_k h_k(s_w) |d_true| + e_w,
// with h_k the hat functions of the knots (h_k(s_k) = 1, linear to 0 at the
// neighbouring knots; h_0 = 1 below s_0 and h_{K-1} = 1 above s_{K-1}, the
// table's constant ends). Linear least squares in r = (r_0..r_{K-1}):
//   r = (X^T X)^-1 X^T y,  Cov r = sigma^2 (X^T X)^-1,
//   sigma^2 = |y - X r|^2 / (W - K)   (m^2 per window, along the motion).
// The residual weights every window by |d_true|, so the fast windows that
// decide the fall-off weigh most; windows with s_w below min_speed (the
// ratio of two near-zero displacements) are left out.
//
// Gauge: the counts tell only the product of the mount's per-axis scale and
// the ratio. The fitted table is divided by r_0 and the mount's scale
// multiplied by it: the table is 1 at its first knot and the scale is the
// sensor's resolution there. The 1-sigma of r_k / r_0 follows from Cov r
// (first order):
//   var(r_k / r_0) = (var r_k - 2 q cov(r_k, r_0) + q^2 var r_0) / r_0^2,  q = r_k / r_0,
// zero at the first knot.
//
// With the mounts: the exact fit (exact.hpp) sees a sensor that under-counts
// at speed as a misfit, so the two alternate: the exact fit, the table at its
// mounts, the exact fit again on the counts with the tables undone
// (corrected_counts, core/sensor.hpp: what the pipeline does), and so on,
// until a round moves no ratio and no mount scale by more than settle (5 %)
// of its 1-sigma (at most max_rounds rounds). The ratios r_k / r_0 hardly depend on
// the mount's scale, so the rounds mostly settle the gauge r_0 (the
// speed-scale scenario, seed 1: 2 rounds).
#pragma once

#include <optional>
#include <span>
#include <string>
#include <variant>
#include <vector>

#include "moa/calibration/calibrate.hpp"
#include "moa/calibration/exact.hpp"

namespace moa {

struct SpeedScaleOptions {
  std::vector<double> knots;  ///< m/s, strictly increasing, 2..SpeedScale::kMaxKnots
  /// m/s: windows where the sensor moves slower are not used.
  double min_speed = 0.05;
  /// A knot needs at least this many windows near it (nearer to it than to
  /// any other knot: h_k(s_w) >= 1/2); fewer and the data do not cover it
  /// (refused: its ratio would be an extrapolation).
  double min_windows = 20.0;
  int max_rounds = 8;  ///< exact fit and table, alternated
  /// Settled when a round moves every ratio and every mount scale by at most
  /// this fraction of its 1-sigma (and r_0 within it of 1, in the sensor's
  /// smallest ratio 1-sigma).
  double settle = 0.05;
};

/// One sensor's fitted table.
struct SpeedScaleFit {
  std::vector<double> knots;     ///< m/s
  std::vector<double> ratios;    ///< r_k / r_0
  std::vector<double> sigma;     ///< 1-sigma of r_k / r_0 (0 at the first knot)
  std::vector<double> coverage;  ///< windows near each knot (h_k >= 1/2)
  double first_ratio = 1.0;      ///< r_0, moved into the mount's scale
  double residual_rms = 0.0;     ///< m per window, along the motion
  int windows = 0;               ///< windows used
  double max_speed = 0.0;        ///< m/s, the fastest window's
};

/// Why the table could not be fitted.
struct SpeedScaleError {
  enum class Kind {
    kBadKnots,    ///< knots not a usable table (SpeedScale's rules, ratios aside)
    kNotCovered,  ///< a knot with too few windows near it
    kSingular,    ///< X^T X not invertible
    kBadTable,    ///< the fitted table is refused (a ratio out of range, not invertible)
  } kind = Kind::kBadKnots;
  int sensor = -1;                         ///< kNotCovered, kSingular, kBadTable
  std::optional<SpeedScale::Error> table;  ///< kBadKnots, kBadTable
  int knot = -1;                           ///< kNotCovered, kBadKnots
  double knot_speed = 0.0;                 ///< m/s, kNotCovered
  double coverage = 0.0;                   ///< windows near the knot (h_k >= 1/2)
  double needed = 0.0;                     ///< SpeedScaleOptions::min_windows
  double max_speed = 0.0;                  ///< m/s, the sensor's fastest window
  /// "sensor 'm1': ..." with `names` (one per sensor), "sensor 2: ..." without.
  std::string message(std::span<const std::string> names = {}) const;
};

/// Each sensor's table at the mounts of `array` (no gauge move: ratios are
/// r_k / r_0, first_ratio r_0).
std::variant<std::vector<SpeedScaleFit>, SpeedScaleError> fit_speed_scales(
    const SensorArray& array, std::span<const CalibrationSample> samples,
    const SpeedScaleOptions& options);

/// The samples with each sensor's counts corrected by its mount's table
/// (corrected_counts, core/sensor.hpp).
std::vector<CalibrationSample> undo_speed_scales(const SensorArray& array,
                                                 std::span<const CalibrationSample> samples);

struct SpeedScaleCalibration {
  ExactCalibration exact;  ///< the last exact fit (on corrected counts), the tables in its mounts
  std::vector<SpeedScaleFit> fits;  ///< per sensor
  int rounds = 0;
  bool converged = false;  ///< the tables settled within max_rounds
};

/// The exact fit and the tables, alternated (header comment).
std::variant<SpeedScaleCalibration, CalibrationError, SpeedScaleError> calibrate_exact_speed_scale(
    const SensorArray& nominal, std::span<const CalibrationSample> samples,
    const SpeedScaleOptions& options, const ExactOptions& exact = {});

}  // namespace moa
