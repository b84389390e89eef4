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
// The array's own rotation has an error of its own that does not average
// out: a sensor mounted eps rad off its configured yaw, at distance r from
// the centre, turns the robot's speed v into an apparent rotation of about
// v eps / r (Kim & Lee's sensitivity of the estimate to mounting errors;
// on a 1.5 cm array 0.05 deg of yaw reads 0.3 m/s as 0.017 rad/s). Over a
// run it is linear in the robot's velocity: omega_a = omega + a . v, so
// a = (a_x, a_y) (rad/m) are two more states, with initial sd
// mount_yaw_sigma / r_rms, r_rms the sensors' rms distance from the centre.
// The states: x = (b, s, a_x, a_y).
//
// Calibration over windows: where the array's twist is trusted, with the
// same sensors and no noise inflation, epoch after epoch, the gyro's angle
// G = sum g dt over a window of T s (at most window_time) measures the
// states against the array's angle A = sum omega_a dt and displacement
// D = sum v_a dt (robot frame):
//   y = G - (k (1 + s) (A - a . D) + (c + b) T),
//   H = (T, k (A - a . D), -k (1 + s) D_x, -k (1 + s) D_y),
//   R = d^2 T + (k (1 + s))^2 (q + sum dt^2 n),
// q the angle variance of the counts' quantisation, which a sum of counts
// carries once whatever its length (its two end residuals), n an epoch's
// rotation variance less its quantisation (the sensors' noise and the
// resolution's variation, noise_model.hpp). The per-epoch model counts the
// quantisation every epoch: at rest on a 1.5 cm array 0.04 rad/s per epoch
// where the window's sum is known to 0.6 mrad. Fused by the one gated update
// (kalman.hpp) at the estimator's alpha. The array's twist fused with the
// gyro each epoch is decoupled the same way: omega_a - a . v_a, its
// variance grown by v_a^T P_aa v_a.
#pragma once

#include <optional>

#include "moa/core/kalman.hpp"
#include "moa/core/options_check.hpp"
#include "moa/core/real.hpp"

namespace moa {

/// The config's `imu:` block (docs/formats/config.md).
struct GyroOptions {
  real scale = 1.0;               ///< k: reading per true rate
  real bias = 0.0;                ///< c, rad/s: reading at rest
  real noise_density = 1.5e-4;    ///< d, rad/s/sqrt(Hz)
  real bias_random_walk = 1e-4;   ///< w, rad/s/sqrt(s)
  real bias_sigma = 0.05;         ///< rad/s, initial sd of b
  real scale_sigma = 0.03;        ///< initial sd of s
  real mount_yaw_sigma = 0.0035;  ///< rad, sd of a sensor's yaw mount error (0.2 deg)
  real max_rate = 8.7;            ///< rad/s, the full scale (500 deg/s)
  double latency = 0.0;           ///< s: a row's t minus the true end of its interval
  real window_time = 0.5;         ///< s, longest calibration window
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

  /// `r_rms`: the sensors' rms distance from the robot's centre (m).
  explicit GyroModel(const GyroOptions& options = {}, real r_rms = 0.1);

  /// Grows the bias uncertainty over dt s.
  void predict(real dt);
  /// The calibrated rate of reading g over dt; nullopt when saturated or not
  /// finite.
  std::optional<GyroRate> rate(real g, real dt) const;
  /// One epoch of a calibration window: the gyro's reading g, the array's
  /// twist x_a; `q` and `n` the angle variances of the array's sensors
  /// (quantisation once per window, rad^2; the rest per epoch, rad^2/s^2).
  /// The window is closed (and fused at the gate q(1 - alpha, 1)) when it
  /// reaches window_time; returns the status of a window closed.
  std::optional<AidStatus> teach(real g, real dt, const Vec3& x_a, real q, real n, real gate);
  /// Closes the window now (the array not trusted, other sensors, an
  /// inflated noise): fused when it holds anything.
  std::optional<AidStatus> close(real gate);
  /// The array's twist with its rotation's coupling to its velocity removed:
  /// omega_a - a . v_a, the variance grown by v_a^T P_aa v_a.
  void decouple(Vec3& x_a, Mat3& c_a) const;

  real bias() const { return options_.bias + x_(0); }                ///< c + b, rad/s
  real scale() const { return options_.scale * (real(1) + x_(1)); }  ///< k (1 + s)
  const Vec2 coupling() const { return x_.tail<2>(); }               ///< a, rad/m
  const Mat4& covariance() const { return p_; }                      ///< of (b, s, a_x, a_y)

 private:
  GyroOptions options_;
  Vec4 x_ = Vec4::Zero();
  Mat4 p_ = Mat4::Zero();
  struct Window {
    real t = 0, gyro = 0, array = 0, noise = 0, q = 0;  ///< s, rad, rad, rad^2, rad^2
    Vec2 displacement = Vec2::Zero();                   ///< m, robot frame
  } window_;
};

}  // namespace moa
