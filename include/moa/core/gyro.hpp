// A z-axis rate gyro (MEMS, MPU-6050 class) as a source of the consensus
// estimator (consensus.hpp): its model, its calibration states and its
// reading over an epoch.
//
// Measurement model, for the rate g (rad/s) averaged over an epoch of dt s
// while the robot turns at omega (rad/s, counter-clockwise about z):
//   g = k (1 + s) omega + c + b + n,   n ~ N(0, d^2 / dt),
// k and c the configured scale and bias (config `imu:`, GyroOptions), s the
// scale error and b the bias error left (the states x = (b, s), covariance
// P), d the noise density (rad/s/sqrt(Hz)): a rate averaged over dt has
// variance d^2 / dt. Between epochs b walks: P_bb grows by w^2 dt, w the bias
// random walk (rad/s/sqrt(s)); s is constant.
//
// The gyro's rate: omega_g = (g - c - b) / (k (1 + s)), with variance
//   d^2 / (dt k^2 (1 + s)^2) + J P J^T,  J = d omega_g / d(b, s)
//                                          = -(1 / (k (1 + s)), omega_g / (1 + s)),
// so an uncalibrated gyro (P from the initial bias_sigma and scale_sigma)
// is wide and counts for little until the array has taught it.
//
// Calibration: where the array's twist is trusted (omega_a, variance v_a;
// at rest too, where it teaches the bias alone), g is a measurement of x:
//   y = g - (k (1 + s) omega_a + c + b),   H = (1, k omega_a),
//   R = d^2 / dt + (k (1 + s))^2 v_a,
// fused by the one gated update (kalman.hpp) at the estimator's alpha.
// A reading within a fraction kSaturation of max_rate is saturated and not
// used.
#pragma once

#include <optional>

#include "moa/core/kalman.hpp"
#include "moa/core/options_check.hpp"
#include "moa/core/real.hpp"

namespace moa {

/// The config's `imu:` block (docs/formats/config.md).
struct GyroOptions {
  real scale = 1.0;                ///< k: reading per true rate
  real bias = 0.0;                 ///< c, rad/s: reading at rest
  real noise_density = 1.5e-4;     ///< d, rad/s/sqrt(Hz)
  real bias_random_walk = 1e-4;    ///< w, rad/s/sqrt(s)
  real bias_sigma = 0.05;          ///< rad/s, initial sd of b
  real scale_sigma = 0.03;         ///< initial sd of s
  real max_rate = 8.7;             ///< rad/s, the full scale (500 deg/s)
  double latency = 0.0;            ///< s: a row's t minus the true end of its interval
  /// nullopt when usable, else the first field out of its bounds.
  OptionCheck validate() const;
};

/// The gyro's rate over an epoch, calibrated.
struct GyroRate {
  real omega = 0.0;     ///< rad/s, counter-clockwise about the robot's z
  real variance = 0.0;  ///< rad^2/s^2
};

class GyroModel {
 public:
  /// Readings within this fraction of max_rate are saturated.
  static constexpr real kSaturation = real(0.98);

  explicit GyroModel(const GyroOptions& options = {});

  /// Grows the bias uncertainty over dt s.
  void predict(real dt);
  /// The calibrated rate of reading g over dt; nullopt when saturated or not
  /// finite.
  std::optional<GyroRate> rate(real g, real dt) const;
  /// The calibration update from the array's rate omega_a (variance v_a)
  /// at the gate q(1 - alpha, 1).
  AidStatus calibrate(real g, real dt, real omega_a, real v_a, real gate);

  real bias() const { return options_.bias + x_(0); }               ///< c + b, rad/s
  real scale() const { return options_.scale * (real(1) + x_(1)); }  ///< k (1 + s)
  const Mat2& covariance() const { return p_; }                      ///< of (b, s)

 private:
  GyroOptions options_;
  Vec2 x_ = Vec2::Zero();
  Mat2 p_ = Mat2::Zero();
};

}  // namespace moa
