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
// The states: x = (b, s, a_x, a_y), and below e and delta.
//
// Calibration over windows: where the array's twist is trusted, with the
// same sensors and no noise inflation, epoch after epoch, the gyro's angle
// G = sum g dt over a window of T s (at most window_time) measures the
// states against the array's angle A = sum omega_a dt and displacement
// D = sum v_a dt (robot frame). The counts' quantisation does not average
// out over a window, but it does not grow either: the array's angle summed
// since a chain of windows began is the true one plus e, the residual of
// the counts not yet whole (variance q / 2 at any instant, q the angle
// variance of a difference of two such residuals, noise_model.hpp). Over a
// window the angle is off by e' - e, e' the residual at its end. So e is a
// fifth state, and a window, with e' appended as a
// fresh state of variance q / 2, measures
//   y = G - (k (1 + s) (A - a . D) + (c + b) T),
//   H = (T, k (A - a . D), -k (1 + s) D_x, -k (1 + s) D_y, k (1 + s), 0, -k (1 + s)),
//   R = d^2 T + (k (1 + s))^2 sum dt^2 n,
// n an epoch's rotation variance less its quantisation (the sensors' noise
// and the resolution's variation); after the update e' is the new e.
// Consecutive windows share their end residuals, which telescope: over a
// chain of total length T_c the bias is learnt to about sqrt(q) / T_c, not
// sqrt(q) / T per window of T (on a 1.5 cm array sqrt(q) is 0.6 mrad: 2 mrad/s
// from one window of 0.3 s, 0.06 mrad/s over 10 s). A break (other sensors,
// an untrusted epoch, a window rejected) starts a new chain: e unknown,
// variance q / 2, uncorrelated. Fused by the one gated update (kalman.hpp) at
// the estimator's alpha; a rejected window breaks the chain. The array's
// rotation tested against the gyro each epoch is decoupled the same way:
// omega_a - a . v_a, its variance grown by v_a^T P_aa v_a.
//
// The heading. The gyro's rate is smooth but its bias error is the same
// epoch after epoch: taken in as if it were white, an error of 3 mrad/s in b
// turns the heading by 1.7 deg in 10 s, where the array alone on a 1.5 cm
// base drifts by less. So the rotation an epoch reports is the gyro's,
// omega_g, and the heading's error it leaves, delta (rad, the reported
// heading minus the true one), is a sixth state, x = (b, s, a_x, a_y, e,
// delta), propagated each epoch the gyro drives the heading by
//   delta <- delta + dt (omega_g - omega) = delta + dt (b, s)-linear + dt n_g,
// so it is correlated with the bias and scale states. A window that corrects
// b and s corrects delta through that correlation: the heading reported with
// the old bias is taken back (the optimal filter for the heading with an
// unknown bias: no worse than the array's own heading, and the gyro's
// smoothness between windows). The correction is reported as rotation,
// spread over window_time: an epoch reports omega_g - c / dt, c = delta
// min(1, dt / window_time), and delta's estimate drops by c (the reported
// heading moved by -c); its variance and correlations stay. An epoch whose
// rotation is not the gyro's (a saturated reading, a gyro blamed for its
// disagreement with the array) grows delta by that rotation's own error,
// dt^2 var, and takes its estimate back the same way.
//
// The latency. A robot program's stamps are off by milliseconds: the gyro's
// rows cover the interval ending tau s before the one the config's latency
// says, tau unknown (prior sd latency_sigma). Then g(t) reads the rate of
// t - tau, omega(t - tau) ~ omega(t) - tau omegadot(t): harmless at a steady
// rate, but in a turn's acceleration a few milliseconds read tens of mrad/s
// off the array's rotation, which the tests blame and the windows would
// learn as bias and scale. tau is a seventh state, x = (b, s, a_x, a_y, e,
// delta, tau). Over a window of readings g_0 .. g_1 (the epoch before it and
// its last), the angle read is k (1 + s) (A - tau (omega_1 - omega_0)), so
// the window's H gains -(g_1 - g_0) for tau (the readings' own difference,
// which k (1 + s) multiplies already). An epoch's rate is corrected to
// omega_g + tau omegadot, omegadot = (g - g_prev) / (k dt), its variance
// grown by omegadot^2 P_tautau, and delta grows by -dt omegadot tau.
// The difference of two readings is noisy (variance 2 d^2 / dt): below
// kSlopeNoise of its sd it is taken as zero, so at rest and at a steady rate
// tau neither moves nor is learnt from noise (a state the data cannot see).
// latency() is the config's latency plus tau, the rows' true latency.
//
// A bias step. A part's bias that jumps (a knock, a temperature step) is
// no random walk: a window's gate rejects it, or passes it at a fraction of
// the step, and the bias would be learnt over minutes. The windows'
// normalised innovations, z = y / sqrt(H P H^T + R) (N(0, 1) while the model
// holds; clipped at the gate, so one gross window moves the test by a
// bounded step), feed two one-sided CUSUMs (cusum.hpp) with reference
// kStepShift = 0.5 sd and an alarm level from kStepFalseAlarmTime, one false
// alarm an hour in windows of window_time while the model holds. An alarm is
// a bias step of unknown size: P_bb grows by bias_sigma^2 (its correlations
// kept) and the bias is learnt afresh, the statistics restart, and
// bias_resets() counts it. The heading the step turned before the alarm is
// not taken back.
#pragma once

#include <cmath>
#include <limits>
#include <optional>

#include "moa/core/cusum.hpp"
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
  real latency_sigma = 0.005;     ///< s, sd of latency (stamps off by milliseconds)
  real window_time = 0.1;         ///< s, longest calibration window
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
  /// A difference of two readings under this many of its sds is no change
  /// of rate (the latency's regressor, above).
  static constexpr real kSlopeNoise = real(5);
  /// The states' count and indices.
  static constexpr int kStates = 7;
  static constexpr int kDelta = 5, kLatency = 6;
  /// The bias step's CUSUM: reference (sd) and mean time between false
  /// alarms (s) while the model holds.
  static constexpr real kStepShift = real(0.5);
  static constexpr real kStepFalseAlarmTime = real(3600);

  /// `r_rms`: the sensors' rms distance from the robot's centre (m).
  explicit GyroModel(const GyroOptions& options = {}, real r_rms = 0.1);

  /// An epoch of dt s whose reading is g (rad/s): grows the bias
  /// uncertainty and takes the change of rate since the reading before
  /// (the latency's regressor; none across a saturated or missing reading).
  void predict(real dt, real g);
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
  /// inflated noise): fused when it holds anything; the next window starts a
  /// new chain.
  std::optional<AidStatus> close(real gate) { return close(gate, false); }
  /// The rotation of an epoch the gyro drives the heading with its rate
  /// `r` (from rate()): omega_g less the heading's error estimated so far,
  /// delta / dt; delta propagated and its estimate reset (above).
  real drive(const GyroRate& r, real dt);
  /// An epoch whose rotation is another source's (the array's, the wheels',
  /// the hold's; `variance` its variance, rad^2/s^2): delta is not the
  /// gyro's to grow, but that source's error integrated, variance dt^2 more;
  /// its estimate is taken back as drive() takes it. Returns the rate to add
  /// to the rotation reported (rad/s, -correction / dt).
  real hold(real variance, real dt);
  /// Forgets delta (its linearisation no longer holds).
  void release();
  /// The array's twist with its rotation's coupling to its velocity removed:
  /// omega_a - a . v_a, the variance grown by v_a^T P_aa v_a (for the gyro's
  /// test of the array's rotation).
  void decouple(Vec3& x_a, Mat3& c_a) const;

  const GyroOptions& options() const { return options_; }
  real bias() const { return options_.bias + x_(0); }                ///< c + b, rad/s
  real scale() const { return options_.scale * (real(1) + x_(1)); }  ///< k (1 + s)
  Vec2 coupling() const { return x_.segment<2>(2); }                 ///< a, rad/m
  /// s, the rows' latency: the config's plus tau
  double latency() const { return options_.latency + static_cast<double>(x_(kLatency)); }
  real latency_sd() const { return std::sqrt(p_(kLatency, kLatency)); }  ///< s, sd of latency()
  /// of (b, s, a_x, a_y, e, delta, tau)
  const Mat<kStates, kStates>& covariance() const { return p_; }
  real bias_sd() const { return std::sqrt(p_(0, 0)); }  ///< rad/s, sd of bias()
  long bias_resets() const { return bias_resets_; }     ///< bias steps found so far
  real scale_sd() const { return options_.scale * std::sqrt(p_(1, 1)); }  ///< sd of scale()

 private:
  GyroOptions options_;
  Mat<kStates, 1> x_ = Mat<kStates, 1>::Zero();
  Mat<kStates, kStates> p_ = Mat<kStates, kStates>::Zero();
  bool chained_ = false;  ///< e is the residual at the open window's start
  TwoSidedCusum step_;    ///< of the windows' normalised innovations
  real step_h_ = 0;       ///< its alarm level, sd
  long bias_resets_ = 0;
  /// rad/s, the readings predict() took last and the one before (NaN: none,
  /// or saturated)
  real last_g_ = std::numeric_limits<real>::quiet_NaN();
  real previous_g_ = std::numeric_limits<real>::quiet_NaN();
  real change_ = 0;           ///< rad/s, last_g_ - previous_g_ beyond its noise, else 0
  real previous_change_ = 0;  ///< rad/s, change_ an epoch before
  struct Window {
    real t = 0, gyro = 0, array = 0, noise = 0, q = 0;  ///< s, rad, rad, rad^2, rad^2
    Vec2 displacement = Vec2::Zero();                   ///< m, robot frame
    /// rad/s, the reading before the window's first epoch (NaN: none) and
    /// its last epoch's; s, that epoch's length
    real g0 = std::numeric_limits<real>::quiet_NaN(), g1 = 0, dt = 0;
    real c0 = 0, c1 = 0;  ///< rad/s, each edge reading's change over its epoch
    bool still = true;    ///< every epoch at rest (zero twist, no noise)
  } window_;
  /// The change of reading a - b (rad/s) over readings of epochs of dt s:
  /// 0 within kSlopeNoise sds of its noise, or when either is missing.
  real change(real a, real b, real dt) const;
  /// Fuses the window; `chain`: the next window begins where it ends.
  std::optional<AidStatus> close(real gate, bool chain);
};

}  // namespace moa
