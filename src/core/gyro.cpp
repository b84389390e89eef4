#include "moa/core/gyro.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace moa {

OptionCheck GyroOptions::validate() const {
  return OptionsCheck()
      .positive("scale", scale)
      .require(std::isfinite(bias), "bias", "finite", bias)
      .positive("noise_density", noise_density)
      .non_negative("bias_random_walk", bias_random_walk)
      .positive("bias_sigma", bias_sigma)
      .positive("scale_sigma", scale_sigma)
      .positive("mount_yaw_sigma", mount_yaw_sigma)
      .positive("max_rate", max_rate)
      .closed("latency", latency, -1.0, 1.0)
      .positive("latency_sigma", latency_sigma)
      .positive("window_time", window_time)
      .result();
}

GyroModel::GyroModel(const GyroOptions& options, real r_rms) : options_(options) {
  // A sensor at the centre (one sensor unit, r_rms -> 0) reads rotation not at
  // all; 5 mm bounds the coupling's prior.
  const real a = options.mount_yaw_sigma / std::max(r_rms, real(0.005));
  p_.diagonal().head<4>() << options.bias_sigma * options.bias_sigma,
      options.scale_sigma * options.scale_sigma, a * a, a * a;
  p_(kLatency, kLatency) = options.latency_sigma * options.latency_sigma;
  // Two statistics, a window every window_time s.
  step_h_ = cusum_threshold(kStepShift, 2 * kStepFalseAlarmTime / options.window_time);
}

real GyroModel::change(real a, real b, real dt) const {
  const real d = a - b;
  if (!std::isfinite(d) || !(dt > 0)) return 0;
  // Two readings of variance noise_density^2 / dt each.
  const real sd = std::sqrt(real(2) / dt) * options_.noise_density;
  return std::abs(d) > kSlopeNoise * sd ? d : real(0);
}

void GyroModel::predict(real dt, real g) {
  p_(0, 0) += options_.bias_random_walk * options_.bias_random_walk * dt;
  const bool read = std::isfinite(g) && std::abs(g) < kSaturation * options_.max_rate;
  previous_change_ = change_;
  previous_g_ = last_g_;
  last_g_ = read ? g : std::numeric_limits<real>::quiet_NaN();
  change_ = change(last_g_, previous_g_, dt);
}

std::optional<GyroRate> GyroModel::rate(real g, real dt) const {
  if (!std::isfinite(g) || !(dt > 0) || std::abs(g) >= kSaturation * options_.max_rate) {
    return std::nullopt;
  }
  const real k = scale();
  GyroRate out;
  out.omega = (g - bias()) / k;
  // The rate of t - tau taken forward to t: + tau omegadot.
  const real omegadot = change_ / (k * dt);
  // d omega / d (b, s, tau), and the states' covariance over them.
  const Vec3 j(-real(1) / k, -out.omega / (real(1) + x_(1)), omegadot);
  out.omega += x_(kLatency) * omegadot;
  constexpr std::array<int, 3> kIndex{0, 1, kLatency};
  Mat3 p;
  for (std::size_t a = 0; a < 3; ++a) {
    for (std::size_t b = 0; b < 3; ++b)
      p(static_cast<int>(a), static_cast<int>(b)) = p_(kIndex[a], kIndex[b]);
  }
  const real d = options_.noise_density;
  out.variance = d * d / (dt * k * k) + j.dot(p * j);
  return out;
}

real GyroModel::drive(const GyroRate& r, real dt) {
  // delta grows by dt (omega_g - omega), omega_g computed with the estimates
  // of b and s, omega = (g - c - b) / (k (1 + s)) with their true values: so
  // F = I with F(delta, (b, s, tau)) = dt (1 / (k (1 + s)), omega / (1 + s),
  // -omegadot), and Q_delta = dt^2 d^2 / (dt k^2).
  const real k = scale();
  Mat<kStates, kStates> f = Mat<kStates, kStates>::Identity();
  f(kDelta, 0) = dt / k;
  f(kDelta, 1) = dt * r.omega / (real(1) + x_(1));
  f(kDelta, kLatency) = -change_ / k;
  p_ = f * p_ * f.transpose();
  const real d = options_.noise_density;
  p_(kDelta, kDelta) += d * d * dt / (k * k);
  // Beyond 1 rad the heading's error is no longer small (the linearisation)
  // and in single precision its variance would swamp the calibration's:
  // the error is forgotten and tracked afresh.
  if (p_(kDelta, kDelta) > real(1)) release();
  // The heading's error estimated so far is taken back over window_time (a
  // rate, not a step: the twist is a controller's input too).
  const real correction = x_(kDelta) * std::min(real(1), dt / options_.window_time);
  x_(kDelta) -= correction;
  return r.omega - correction / dt;
}

void GyroModel::decouple(Vec3& x_a, Mat3& c_a) const {
  const Vec2 v = x_a.head<2>();
  x_a(2) -= coupling().dot(v);
  c_a(2, 2) += v.dot(p_.block<2, 2>(2, 2) * v);
}

real GyroModel::hold(real variance, real dt) {
  if (!(dt > 0)) return 0;
  p_(kDelta, kDelta) += variance * dt * dt;
  if (p_(kDelta, kDelta) > real(1)) release();
  const real correction = x_(kDelta) * std::min(real(1), dt / options_.window_time);
  x_(kDelta) -= correction;
  return -correction / dt;
}

void GyroModel::release() {
  x_(kDelta) = 0;
  p_.row(kDelta).setZero();
  p_.col(kDelta).setZero();
}

std::optional<AidStatus> GyroModel::teach(real g, real dt, const Vec3& x_a, real q, real n,
                                          real gate) {
  if (!rate(g, dt)) return close(gate);
  if (!(window_.t > 0)) {
    // The reading before the window, or with none its own first (the
    // change over that one epoch is then missed).
    window_.g0 = std::isfinite(previous_g_) ? previous_g_ : g;
    window_.c0 = std::isfinite(previous_g_) ? previous_change_ : change_;
    window_.still = true;
  }
  // At rest (the rotation known to be zero: no array twist, no noise) the
  // readings' true change is zero, whatever the latency.
  window_.still = window_.still && x_a.isZero(0) && n == 0 && q == 0;
  window_.g1 = g;
  window_.c1 = change_;
  window_.dt = dt;
  window_.t += dt;
  window_.gyro += g * dt;
  window_.array += x_a(2) * dt;
  window_.displacement += x_a.head<2>() * dt;
  window_.noise += n * dt * dt;
  window_.q = q;
  if (window_.t < options_.window_time) return std::nullopt;
  return close(gate, true);
}

std::optional<AidStatus> GyroModel::close(real gate, bool chain) {
  if (!(window_.t > 0)) {
    chained_ = false;
    return std::nullopt;
  }
  const Window w = window_;
  window_ = Window{};
  if (!chained_) {  // a new chain: the residual at the start is unknown
    x_(4) = 0;
    p_.row(4).setZero();
    p_.col(4).setZero();
    p_(4, 4) = w.q / 2;
  }
  // The states with the residual at the window's end appended (gyro.hpp).
  constexpr int kEnd = kStates;  // e', appended
  Mat<kStates + 1, 1> x;
  x << x_, real(0);
  Mat<kStates + 1, kStates + 1> p = Mat<kStates + 1, kStates + 1>::Zero();
  p.topLeftCorner<kStates, kStates>() = p_;
  p(kEnd, kEnd) = w.q / 2;
  const real k = scale();
  const Vec2& d = w.displacement;
  const real angle = w.array - coupling().dot(d);  // the array's, decoupled
  // The readings' change over the window, k (1 + s) (omega_1 - omega_0).
  // The latency's regressor is the change of rate between the window's
  // edges less tau / 2, k (1 + s) (omega(t_1 - tau/2) - omega(t_0 - tau/2));
  // a reading is its epoch's mean, tau + dt / 2 before those instants: each
  // edge's reading is taken forward by that much along its epoch's change.
  const real lead = (w.dt / 2 + x_(kLatency) / 2) / w.dt;
  const real dg = w.still ? real(0) : change(w.g1, w.g0, w.dt) + lead * (w.c1 - w.c0);
  const Mat<1, 1> y(w.gyro - (k * angle + bias() * w.t - x_(kLatency) * dg));
  Mat<1, kStates + 1> h;
  h << w.t, options_.scale * angle, -k * d.x(), -k * d.y(), k, 0, -dg, -k;
  const real nd = options_.noise_density;
  // The regressor's own noise (two readings, 2 d^2 / dt), or the change
  // taken as none (up to kSlopeNoise of its sd), times the latency's
  // second moment.
  const real dg_var =
      w.still ? real(0)
              : real(2) * nd * nd / w.dt * (dg == 0 ? kSlopeNoise * kSlopeNoise : real(1));
  const real tau2 = x_(kLatency) * x_(kLatency) + p_(kLatency, kLatency);
  const Mat<1, 1> r(nd * nd * w.t + k * k * w.noise + tau2 * dg_var);
  // The bias step's test, on the innovation before the update.
  const real z = y(0) / std::sqrt(innovation_covariance<kStates + 1, 1>(p, h, r)(0, 0));
  const real clip = std::sqrt(gate);
  if (std::isfinite(z) && step_.feed(std::clamp(z, -clip, clip), kStepShift, step_h_)) {
    // A step of unknown size: bias_sigma^2 more of bias uncertainty (the
    // other states' correlations with it kept), learnt afresh from here on.
    p(0, 0) += options_.bias_sigma * options_.bias_sigma;
    step_.reset();
    ++bias_resets_;
  }
  const AidStatus status = gated_update<kStates + 1, 1>(x, p, y, h, r, gate);
  chained_ = chain && status.fused;
  // The residual at the end becomes the start's (the chain goes on, and the
  // next window's start) or is forgotten (a new chain): e' takes e's place.
  const std::array<int, kStates> keep{0, 1, 2, 3, kEnd, kDelta, kLatency};
  for (std::size_t a = 0; a < keep.size(); ++a) {
    x_(static_cast<int>(a)) = x(keep[a]);
    for (std::size_t b = 0; b < keep.size(); ++b) {
      p_(static_cast<int>(a), static_cast<int>(b)) = p(keep[a], keep[b]);
    }
  }
  return status;
}

}  // namespace moa
