#include "moa/core/gyro.hpp"

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
      .positive("max_rate", max_rate)
      .closed("latency", latency, -1.0, 1.0)
      .result();
}

GyroModel::GyroModel(const GyroOptions& options) : options_(options) {
  p_(0, 0) = options.bias_sigma * options.bias_sigma;
  p_(1, 1) = options.scale_sigma * options.scale_sigma;
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
  out.variance = d * d / (dt * k * k) + (j * p_ * j.transpose())(0, 0);
  return out;
}

AidStatus GyroModel::calibrate(real g, real dt, real omega_a, real v_a, real gate) {
  if (!rate(g, dt)) return {};
  const real k = scale();
  const Mat<1, 1> y(g - (k * omega_a + bias()));
  const Mat<1, 2> h(real(1), options_.scale * omega_a);
  const real d = options_.noise_density;
  const Mat<1, 1> r(d * d / dt + k * k * v_a);
  return gated_update<2, 1>(x_, p_, y, h, r, gate);
}

}  // namespace moa
