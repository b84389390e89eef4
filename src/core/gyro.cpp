#include "moa/core/gyro.hpp"

#include <algorithm>
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
  p_.diagonal() << options.bias_sigma * options.bias_sigma,
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

void GyroModel::decouple(Vec3& x_a, Mat3& c_a) const {
  const Vec2 v = x_a.head<2>();
  x_a(2) -= x_.tail<2>().dot(v);
  c_a(2, 2) += v.dot(p_.bottomRightCorner<2, 2>() * v);
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
  return close(gate);
}

std::optional<AidStatus> GyroModel::close(real gate) {
  if (!(window_.t > 0)) return std::nullopt;
  const Window w = window_;
  window_ = Window{};
  const real k = scale();
  const Vec2& d = w.displacement;
  const real angle = w.array - x_.tail<2>().dot(d);  // the array's, decoupled
  const Mat<1, 1> y(w.gyro - (k * angle + bias() * w.t));
  const Mat<1, 4> h(w.t, options_.scale * angle, -k * d.x(), -k * d.y());
  const real nd = options_.noise_density;
  const Mat<1, 1> r(nd * nd * w.t + k * k * (w.q + w.noise));
  return gated_update<4, 1>(x_, p_, y, h, r, gate);
}

}  // namespace moa
