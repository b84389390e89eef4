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
      .positive("window_time", window_time)
      .result();
}

GyroModel::GyroModel(const GyroOptions& options, real r_rms) : options_(options) {
  // A sensor at the centre (one sensor unit, r_rms -> 0) reads rotation not at
  // all; 5 mm bounds the coupling's prior.
  const real a = options.mount_yaw_sigma / std::max(r_rms, real(0.005));
  p_.diagonal().head<4>() << options.bias_sigma * options.bias_sigma,
      options.scale_sigma * options.scale_sigma, a * a, a * a;
}

void GyroModel::predict(real dt) {
  p_(0, 0) += options_.bias_random_walk * options_.bias_random_walk * dt;
}

std::optional<GyroRate> GyroModel::rate(real g, real dt) const {
  if (!std::isfinite(g) || !(dt > 0) || std::abs(g) >= kSaturation * options_.max_rate) {
    return std::nullopt;
  }
  const real k = scale();
  GyroRate out;
  out.omega = (g - bias()) / k;
  const Mat<1, 2> j(-real(1) / k, -out.omega / (real(1) + x_(1)));
  const real d = options_.noise_density;
  out.variance = d * d / (dt * k * k) + (j * p_.topLeftCorner<2, 2>() * j.transpose())(0, 0);
  return out;
}

real GyroModel::drive(const GyroRate& r, real dt) {
  // delta grows by dt (omega_g - omega), omega_g computed with the estimates
  // of b and s, omega = (g - c - b) / (k (1 + s)) with their true values: so
  // F = I with F(delta, (b, s)) = dt (1 / (k (1 + s)), omega / (1 + s)), and
  // Q_delta = dt^2 d^2 / (dt k^2).
  const real k = scale();
  Mat<6, 6> f = Mat<6, 6>::Identity();
  f(5, 0) = dt / k;
  f(5, 1) = dt * r.omega / (real(1) + x_(1));
  p_ = f * p_ * f.transpose();
  const real d = options_.noise_density;
  p_(5, 5) += d * d * dt / (k * k);
  // Beyond 1 rad the heading's error is no longer small (the linearisation)
  // and in single precision its variance would swamp the calibration's:
  // the error is forgotten and tracked afresh.
  if (p_(5, 5) > real(1)) release();
  // The heading's error estimated so far is taken back over window_time (a
  // rate, not a step: the twist is a controller's input too).
  const real correction = x_(5) * std::min(real(1), dt / options_.window_time);
  x_(5) -= correction;
  return r.omega - correction / dt;
}

void GyroModel::decouple(Vec3& x_a, Mat3& c_a) const {
  const Vec2 v = x_a.head<2>();
  x_a(2) -= coupling().dot(v);
  c_a(2, 2) += v.dot(p_.block<2, 2>(2, 2) * v);
}

real GyroModel::hold(real variance, real dt) {
  if (!(dt > 0)) return 0;
  p_(5, 5) += variance * dt * dt;
  if (p_(5, 5) > real(1)) release();
  const real correction = x_(5) * std::min(real(1), dt / options_.window_time);
  x_(5) -= correction;
  return -correction / dt;
}

void GyroModel::release() {
  x_(5) = 0;
  p_.row(5).setZero();
  p_.col(5).setZero();
}

std::optional<AidStatus> GyroModel::teach(real g, real dt, const Vec3& x_a, real q, real n,
                                          real gate) {
  if (!rate(g, dt)) return close(gate);
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
  Mat<7, 1> x;
  x << x_, real(0);
  Mat<7, 7> p = Mat<7, 7>::Zero();
  p.topLeftCorner<6, 6>() = p_;
  p(6, 6) = w.q / 2;
  const real k = scale();
  const Vec2& d = w.displacement;
  const real angle = w.array - coupling().dot(d);  // the array's, decoupled
  const Mat<1, 1> y(w.gyro - (k * angle + bias() * w.t));
  Mat<1, 7> h;
  h << w.t, options_.scale * angle, -k * d.x(), -k * d.y(), k, 0, -k;
  const real nd = options_.noise_density;
  const Mat<1, 1> r(nd * nd * w.t + k * k * w.noise);
  const AidStatus status = gated_update<7, 1>(x, p, y, h, r, gate);
  chained_ = chain && status.fused;
  // The residual at the end becomes the start's (the chain goes on, and the
  // next window's start) or is forgotten (a new chain): e' takes e's place.
  const std::array<int, 6> keep{0, 1, 2, 3, 6, 5};
  for (std::size_t a = 0; a < keep.size(); ++a) {
    x_(static_cast<int>(a)) = x(keep[a]);
    for (std::size_t b = 0; b < keep.size(); ++b) {
      p_(static_cast<int>(a), static_cast<int>(b)) = p(keep[a], keep[b]);
    }
  }
  return status;
}

}  // namespace moa
