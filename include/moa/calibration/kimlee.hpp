// Kim & Lee Section IV, as published: position calibration of a mouse array
// against an accurate reference twist (wheel encoders), positions only.
//
// Per measurement k, with the nominal geometry A_bar (eq. (6)), the
// reference twist v_m = (vx, vy, omega) and the measured point velocities
// v_s (2N, robot frame: counts through the nominal G_i^-1):
//   S_k delta_p = b_k                                    eq. (41)
//   S_k = C_1 + C_2  (3 x 2N)                            eqs. (38)-(40), (42)
//     C_1 row 3, sensor i: ( v_iy, -v_ix )
//     C_2 rows 1, 2:       ( 0, omega ) and ( -omega, 0 )
//     C_2 row 3:           ( -vy - 2 omega p_ix, vx - 2 omega p_iy )   (nominal p)
//   b_k = A_bar^T (A_bar v_m - v_s)                      eq. (43)
// Aggregated as the paper does (eqs. (44)-(46)): all of S_1, b_1 and only
// the third row of each later measurement, so S is (M + 2) x 2N. Solved by
// eq. (47) with the inverse of eq. (48) replaced by a rank-revealing
// pseudo-inverse (JacobiSVD): singular values at or below a threshold are
// treated as zero and the minimum-norm delta_p is returned. Eq. (49), M >=
// 2N - 2, is necessary, not sufficient: a constant self-rotation (the
// paper's own example) gives rank 3 whatever M is, and the minimum-norm
// solution then reproduces eq. (53) rather than the true eq. (52).
//
// The threshold. Rows 3.. of S carry the measured velocities, so noise of
// standard deviation sigma (m/s) in each of them gives S a noise part whose
// largest singular value is about sigma (sqrt(rows) + sqrt(2N)) (Gordon's
// bound for a Gaussian matrix). A singular value is kept when it exceeds
//   threshold = factor * sigma * (sqrt(rows) + sqrt(2N)),  factor = 3,
// and in any case 2N * rows * eps * s_max. sigma is the configured one, or
// max(quantisation, min(successive-difference, nominal-LS-residual)) from the
// data: both data estimates can only overstate the noise (motion changes
// between samples, a wrong nominal geometry), so their minimum is the
// tighter of two upper bounds; quantisation (one count difference of two
// roundings, variance 1/6 count^2) is a floor.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <span>
#include <variant>

#include "moa/calibration/calibrate.hpp"

namespace moa {

/// S_k and b_k of eqs. (38)-(43) for one measurement: reference twist
/// `v_m`, measured point velocities `v_s` (N, robot frame, m/s).
struct KimLeeMeasurement {
  Eigen::Matrix<double, 3, Eigen::Dynamic> s;  ///< 3 x 2N, columns (dp_1x, dp_1y, ...)
  Eigen::Vector3d b;
};
KimLeeMeasurement kimlee_measurement(const SensorArray& nominal, const Twist2& v_m,
                                     std::span<const Eigen::Vector2d> v_s);

/// S and b of eqs. (44)-(46) from M measurements.
struct KimLeeSystem {
  Eigen::MatrixXd s;  ///< (M + 2) x 2N
  Eigen::VectorXd b;  ///< M + 2
};
KimLeeSystem kimlee_system(const SensorArray& nominal, std::span<const CalibrationSample> samples);

struct KimLeeOptions {
  double threshold_factor = 3.0;
  /// Standard deviation of one measured velocity component (m/s); estimated
  /// from the data when unset (see the header comment).
  std::optional<double> velocity_noise;
};

struct KimLeeCalibration {
  SensorArray calibrated;            ///< nominal with positions p_bar + delta_p
  Eigen::VectorXd delta_p;           ///< 2N, m (eq. (47), minimum norm)
  Eigen::MatrixXd covariance;        ///< 2N x 2N, m^2, within the solved subspace
  Eigen::VectorXd singular_values;   ///< of S, descending
  int rank = 0;                      ///< singular values above the threshold
  double threshold = 0.0;            ///< in the units of S (m/s)
  double velocity_noise = 0.0;       ///< sigma used for the threshold, m/s
  int measurements = 0;              ///< M
  std::vector<double> residual_rms;  ///< per sensor, m/s: v_s - A(p_calibrated) v_m
  bool rank_deficient() const { return rank < singular_values.size(); }
  /// Eq. (49) violated: M < 2N - 2.
  bool too_few_measurements() const {
    return measurements < 2 * static_cast<int>(delta_p.size() / 2) - 2;
  }
};

/// Kim & Lee's calibration; samples with a lift or overflow flag are skipped.
std::variant<KimLeeCalibration, CalibrationError> calibrate_kimlee(
    const SensorArray& nominal, std::span<const CalibrationSample> samples,
    const KimLeeOptions& options = {});

}  // namespace moa
