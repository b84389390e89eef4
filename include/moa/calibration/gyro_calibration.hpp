// The gyro's scale, bias and latency against a reference rotation rate
// (`moa calibrate`, docs/calibration.md "The gyro").
//
// Model (core/gyro.hpp, with no calibration applied): a gyro row stamped t
// reports the rate averaged over its interval since the previous row, which
// really ended at t - L (L, s: the latency), so the true interval (t0, t1]
// of a reference row is (t0 + L, t1 + L] on the gyro's clock:
//   G_k(L) = (Gamma(t1 + L) - Gamma(t0 + L)) / (t1 - t0) = k w_k + c + n,
// Gamma(t) (rad) the integral of the gyro's rows (piecewise linear, each row
// the average over its interval: exact for any L), k the scale (reading per
// true rate), c the bias (rad/s, the reading at rest), w_k the reference's
// true rate over its row. The reference is the noisy side (the array's
// rotation over 10 ms carries ~0.05 rad/s of count quantisation, the gyro's
// rate 1.5e-4 / sqrt(0.01) = 0.0015 rad/s), so the reference's rows are the
// observations, fixed, and the gyro is what is shifted and resampled:
//   w_k = alpha G_k(L) + beta + gamma . v_k + e_k,
// alpha = 1 / k, beta = -c / k, e_k the reference's noise. Least squares of
// the gyro on the noisy reference instead would shrink k by var(e) / var(w)
// (1.7 % on gyro-bump), and shifting the noisy reference would average its
// noise at fractional shifts and pull L towards them (1.5 ms measured).
// gamma = a (rad/m): the reference's rotation may read its velocity v as
// rotation, omega_ref = omega + a . v (a sensor's yaw mount error eps at
// distance r: v eps / r; wheels that slip unequally); v_k is the
// reference's velocity averaged over its interval widened by 0.25 s each
// side (its noise then is not e_k's: the array's velocity and rotation come
// from the same counts). Without a velocity gamma is not fitted.
//
// 1. Latency, coarse: the Pearson correlation of w_k with G_k(L) over a grid
//    of lags L = j h, h the gyro's median row interval, |L| <= max_latency
//    (as Kalibr aligns the angular rates of two sensors before fitting);
//    the same rows for every lag (those whose shifted intervals lie within
//    the gyro's rows at every lag). The peak, refined by the parabola
//    through it and its two neighbours:
//    L0 = L_j + h (c_- - c_+) / (2 (c_- - 2 c_0 + c_+)).
// 2. (alpha, beta, L, gamma) by Gauss-Newton on r_k = w_k - alpha G_k(L) -
//    beta - gamma . v_k from the linear fit at L0, with
//    dG_k/dL = (g(t1 + L) - g(t0 + L)) / (t1 - t0), g the gyro's (piecewise
//    constant) rate. Rows whose residual exceeds outlier_sigmas robust
//    sigmas (1.4826 MAD) are dropped and the fit repeated (a wheel that
//    slips, the array reading nothing while the robot turns).
// 3. Covariance: the residual is not white (a slipping wheel's error lasts
//    ~0.3 s, the gyro's bias walks), so the sandwich over blocks of
//    block_time s: A^-1 (sum_b J_b^T r_b r_b^T J_b) A^-1, A = J^T J; with
//    fewer than 10 blocks, sigma^2 A^-1 (white residual, sigma^2 its
//    variance); each variance at least the white one's. Then (k, c, L) =
//    (1 / alpha, -beta / alpha, L) through its Jacobian, marginal over gamma.
//
// Refusals: a reference whose rate does not vary (sd below min_rotation:
// the scale cannot be told from the bias), no peak of the correlation within
// +-max_latency or a peak below min_correlation (the two series are not the
// same motion: another run, another clock).
//
// What is estimated is against the reference's clock and scale: a reference
// that reads rotation 5 % high (a slipping wheel over-reads its turn) gives
// a gyro scale 5 % low, and a reference that is late by d gives L - d.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <span>
#include <variant>
#include <vector>

namespace moa {

/// A rotation rate series: rate[k] (rad/s, counter-clockwise) is the
/// average over (t[k], t[k + 1]] (s); t has one more entry than rate.
/// `velocity` (m/s, robot frame, the same intervals; may be empty): the
/// reference's rotation may read its velocity as rotation (a sensor's yaw
/// mount error eps at distance r: v eps / r; wheels that slip unequally),
/// omega_ref = omega + a . v, so the fit takes a (rad/m) too.
struct RateSeries {
  std::vector<double> t;
  std::vector<double> rate;
  std::vector<Eigen::Vector2d> velocity;
};

struct GyroCalibrationOptions {
  double max_latency = 0.5;      ///< s, the coarse search's range of L
  double min_rotation = 0.05;    ///< rad/s, least sd of the reference rate
  double min_correlation = 0.5;  ///< least correlation at the peak
  double outlier_sigmas = 5.0;   ///< robust sigmas beyond which a row is dropped
  double block_time = 1.0;       ///< s, blocks of the covariance's sandwich
};

enum class GyroCalibrationError {
  kTooFewRows,     ///< fewer than 20 reference rows within the gyro's
  kBadInput,       ///< times not increasing, values not finite
  kNoRotation,     ///< the reference does not turn: scale unobservable
  kNoCorrelation,  ///< no correlation peak within +-max_latency
};
const char* describe(GyroCalibrationError error);

struct GyroCalibration {
  double scale = 1.0;    ///< k: reading per true rate
  double bias = 0.0;     ///< c, rad/s: reading at rest
  double latency = 0.0;  ///< L, s: a row's t minus the true end of its interval
  /// Of (scale, bias, latency): (1, rad/s, s).
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  /// a = gamma, rad/s per m/s: the reference's rotation read from its velocity.
  Eigen::Vector2d coupling = Eigen::Vector2d::Zero();  ///< rad/m
  double coarse_latency = 0.0;                         ///< s, the parabola's L0
  double correlation = 0.0;                            ///< at the coarse peak
  double residual_rms = 0.0;                           ///< rad/s, of the reference rows used
  double reference_sd = 0.0;      ///< rad/s, sd of the reference rate over the rows
  std::size_t rows = 0;           ///< reference rows within the gyro's
  std::size_t rows_rejected = 0;  ///< of those, dropped as outliers
  int blocks = 0;                 ///< of the sandwich (0: white covariance)

  double scale_sigma() const { return std::sqrt(covariance(0, 0)); }
  double bias_sigma() const { return std::sqrt(covariance(1, 1)); }
  double latency_sigma() const { return std::sqrt(covariance(2, 2)); }
};

/// The gyro rows (t s, g rad/s, each g the average over the interval since
/// the previous row; the first only opens) against `reference`. Allocates
/// (calibration, not the odometry's path).
std::variant<GyroCalibration, GyroCalibrationError> calibrate_gyro(
    std::span<const double> t, std::span<const double> g, const RateSeries& reference,
    const GyroCalibrationOptions& options = {});

}  // namespace moa
