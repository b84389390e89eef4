// Exact extrinsic calibration: position, yaw, per-axis scale and mirroring
// of every sensor from counts against a noisy reference twist.
//
// Model, per sample k (interval dt_k) and sensor i, in counts:
//   c_ik = H_i z_k + e_ik,     H_i = [M_i | q_i] = G_i A_i (2x3), e_ik ~ N(0, s^2 I)
//   w_k dt_k = z_k + eta_k,    eta_k ~ N(0, dt_k^2 Sigma_w)
// z_k = x_k dt_k is the true robot displacement (m, m, rad) over the
// interval, w_k the reference twist (wheels.csv). Both sides are noisy: an
// errors-in-variables problem. Ordinary least squares on w_k would shrink
// M_i and q_i by about Sigma_w / Cov(x) (a 1 cm/s wheel noise on 0.2 m/s
// motion biases every scale by -0.25 %). So z_k are nuisance unknowns and
// the likelihood is maximised over them in closed form:
//   z_k = (H^T D^-1 H + W_k^-1)^-1 (H^T D^-1 c_k + W_k^-1 w_k dt_k),
//   D = s^2 I (counts^2),  W_k = dt_k^2 Sigma_w,
// leaving, per sample, the residual
//   rho_k = [ D^-1/2 (c_k - H z_k) ;  W_k^-1/2 (w_k dt_k - z_k) ],
//   |rho_k|^2 = r_k^T (D + H W_k H^T)^-1 r_k,   r_k = c_k - H w_k dt_k,
// whose sum is minimised over the free mounting parameters by Eigen's
// Levenberg-Marquardt (minimizeOptimumStorage: memory O(P^2), the Jacobian
// one sample's rows at a time, analytic: only H depends on the parameters,
// and dz_k follows from differentiating the normal equations). With Sigma_w known
// this is the maximum-likelihood (generalised total least squares)
// estimator, consistent where OLS is not.
//
// Noise levels are estimated from the same data, alternating with the fit:
// the mice alone give z~_k = (H^T H)^-1 H^T c_k (2N > 3 equations for 3
// unknowns) with error covariance P = s^2 (H^T H)^-1, and
//   s^2 = sum_k |c_k - H z~_k|^2 / (K (2N - 3))   (one variance for all count
//   rows, D = s^2 I: per-sensor variances from these residuals can collapse
//   onto one sensor when the noise is far from isotropic, as when an axis
//   that never moves has no quantisation noise at all)
//   Sigma_w = (sum_k d_k d_k^T - K P) / sum_k dt_k^2,   d_k = w_k dt_k - z~_k,
// except at the start, where d_k is first cleared of its least-squares
// regression on z~_k (and K of d d^T becomes K / (K - 3)): there the part
// of w - z~ linear in z~ is the misfit of the nominal geometry, not noise,
// and left in it would make the reference look noisy, the fit trust it too
// little and stay near the start.
//
// Start: per sensor, the OLS fit H_i = C_i Z^T (Z Z^T)^-1 split by
// decompose_sensor_matrix() (this is where mirroring is found: det M_i < 0)
// when that fit is a plausible sensor matrix, else the nominal mount.
//
// Observability: the Fisher information of all 5N parameters,
//   F = sum_k G_k^T (D + H W_k H^T)^-1 G_k,   G_k = d(H z_k)/d(theta),
// (the Schur complement that removes the unknown z_k; quadratic in z_k),
// with z_k z_k^T estimated by sym(w_k dt_k z~_k^T), the product of two
// independent noisy views of z_k, which is unbiased whatever their noise
// (z_k z_k^T of an estimate would count its noise as excitation: under a
// pure rotation the mice's noise in v would seem to excite yaw and scale),
// decides per sensor
// which parameters are excited (observability.hpp); the others stay at
// nominal, and so does mirroring unless yaw and both scales are estimated.
// The covariance of the estimate is F^-1 over the estimated parameters at
// the estimate; at the true values and noise it is the Cramer-Rao bound.
//
// Samples whose |rho_k|^2 exceeds the chi-square(2N) quantile 1 - 1e-6 are
// rejected (wheel slip, a lifted sensor) when they are at most 5 % of the
// data; more is a model misfit, reported and not rejected.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <span>
#include <variant>
#include <vector>

#include "moa/calibration/calibrate.hpp"
#include "moa/calibration/observability.hpp"

namespace moa {

/// Noise of the exact method's model.
struct CalibrationNoise {
  /// s^2 per sensor, counts^2 per axis and sample (estimated: one value for all)
  std::vector<double> counts_variance;
  Eigen::Matrix3d reference_covariance = Eigen::Matrix3d::Zero();  ///< Sigma_w, (m/s, m/s, rad/s)^2
};

struct ExactOptions {
  /// false: the reference is taken as exact (Sigma_w ~ 0), i.e. weighted OLS.
  bool errors_in_variables = true;
  std::optional<CalibrationNoise> noise;  ///< known noise; estimated when unset
  ObservabilityOptions observability;
  bool reject_outliers = true;
  int max_iterations = 8;  ///< outer iterations (noise re-estimation)
};

struct SensorCalibration {
  SensorMount nominal;
  SensorMount calibrated;  ///< yaw within pi of the nominal yaw (its representation kept)
  std::array<bool, kMountParameters> estimated{};  ///< false: kept at nominal
  bool mirror_from_data = false;  ///< mirroring decided by the data, not the nominal config
  MountMatrix covariance = MountMatrix::Zero();          ///< of (px, py, yaw, sx, sy); 0 where kept
  double residual_rms = 0.0;                             ///< m/s, sensor point velocity misfit
  MountVector scaled_eigenvalues = MountVector::Zero();  ///< see observability.hpp
};

/// Whether the calibrated model explains the data (docs/calibration.md,
/// "Refused calibrations"). The counts alone say how noisy they are: a
/// rigid robot's 2N count rows span only the 3-dimensional space of its
/// twist, so the residual of the best rank-3 fit of the 2N x K counts
/// (any 2N x 3 H, not only the mounts' form) is noise, s0^2 per count axis
/// and sample with (K - 3)(2N - 3) degrees of freedom. At the calibrated
/// mounts, the counts' own (mice-only) least-squares residual is s^2 with
/// K (2N - 3) degrees of freedom; if the model holds, K (2N - 3) s^2 / s0^2
/// is about chi-square(K (2N - 3)), and s^2 / s0^2 about 1.
struct ExactModelCheck {
  double residual_variance = 0.0;  ///< s^2, counts^2 per axis and sample, at the calibrated mounts
  /// s0^2, counts^2 per axis and sample, at least 1/12 (a count's rounding).
  double noise_variance = 0.0;
  /// Largest s^2 / s0^2 accepted: 4 (twice the noise in RMS), or the
  /// chi-square(K (2N - 3)) quantile 1 - 1e-6 over K (2N - 3) when larger.
  double bound = 0.0;
  /// false: too few samples to know the noise ((K - 3)(2N - 3) < 30): not tested.
  bool tested = false;
  /// Smallest scaled information eigenvalue of any sensor (the report's
  /// "information"); the information is positive semi-definite, so one
  /// below -1 (the excitation threshold, mirrored) is no estimation noise.
  double min_eigenvalue = 0.0;
  int min_eigenvalue_sensor = 0;  ///< whose information has it

  double variance_ratio() const { return residual_variance / noise_variance; }
  bool residual_too_large() const { return tested && !(variance_ratio() <= bound); }
  bool information_indefinite() const { return !(min_eigenvalue >= -1.0); }
  /// The calibration should not be used (moa calibrate refuses it without --force).
  bool misfit() const { return residual_too_large() || information_indefinite(); }
};

struct ExactCalibration {
  std::vector<SensorCalibration> sensors;
  SensorArray calibrated;
  CalibrationNoise noise;      ///< as estimated (or given)
  Eigen::MatrixXd covariance;  ///< 5N x 5N, zero rows and columns for kept parameters
  int samples_used = 0;
  int samples_rejected = 0;   ///< outliers
  int samples_unusable = 0;   ///< flags, non-finite values
  bool model_misfit = false;  ///< too many outliers to reject
  ExactModelCheck check;      ///< does the calibrated model explain the data?
  bool converged = false;
  int iterations = 0;
};

/// The exact method (header comment). Needs at least three usable samples.
std::variant<ExactCalibration, CalibrationError> calibrate_exact(
    const SensorArray& nominal, std::span<const CalibrationSample> samples,
    const ExactOptions& options = {});

/// Fisher information F (5N x 5N, parameters sensor-major in MountParameter
/// order) of the data: true twists `twists` over intervals `dt` seen by
/// `array` with noise `noise`. F^-1 is the Cramer-Rao bound.
Eigen::MatrixXd calibration_information(const SensorArray& array, std::span<const Twist2> twists,
                                        std::span<const double> dt, const CalibrationNoise& noise);

}  // namespace moa
