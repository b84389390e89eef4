#include "moa/core/noise_model.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>

namespace moa {

OptionCheck NoiseModelOptions::validate() const {
  return OptionsCheck()
      .non_negative("relative", relative)
      .positive("speed_onset", speed_onset)
      .at_least("speed_cap", speed_cap, 1.0)
      .closed("min_squal", min_squal, 0, 255)  // SQUAL is one byte
      .at_least("low_squal_factor", low_squal_factor, 1.0)
      .at_least("overflow_factor", overflow_factor, 1.0)
      .result();
}

real NoiseModelOptions::speed_factor(real speed, real max_speed) const {
  if (!(max_speed > 0.0)) return 1.0;
  const real ratio = speed / (speed_onset * max_speed);
  const real r2 = ratio * ratio, r4 = r2 * r2;
  return std::min(speed_cap, 1.0 + r4 * r4);
}

NoiseModel::NoiseModel(const SensorArray& array, NoiseModelOptions options)
    : n_(array.size()), options_(options) {
  for (int i = 0; i < n_ && i < kMaxSensors; ++i) {
    const auto s = static_cast<std::size_t>(i);
    c_[s] = array[i].robot_velocity_from_counts();
    quant_[s] = c_[s] * c_[s].transpose() / 6.0;
    a_[s] = array[i].point_jacobian();
    noise2_[s] = array[i].noise ? *array[i].noise * *array[i].noise : 0.0;
    max_speed_[s] = array[i].max_speed ? *array[i].max_speed : 0.0;
  }
}

Mat3 NoiseModel::quantisation_information(int i) const {
  const auto s = static_cast<std::size_t>(i);
  return a_[s].transpose() * quant_[s].inverse() * a_[s];
}

void NoiseModel::measure(const ArraySample& sample, const Twist2& predicted, PointMeasurements& out,
                         std::array<std::uint8_t, kMaxSensors>& flags) const {
  out.size = n_;
  out.prepared_by = nullptr;
  const Vec3 x = predicted.vector();
  const real inv_dt = 1.0 / sample.dt;
  for (int i = 0; i < n_; ++i) {
    const auto s = static_cast<std::size_t>(i);
    out.u[s] = c_[s] * sample.counts[s] * inv_dt;
    const real predicted_speed = (a_[s] * x).norm();
    const real speed = std::min(out.u[s].norm(), predicted_speed);
    const real rel = options_.relative * speed;
    Mat2 cov = quant_[s] * (inv_dt * inv_dt);
    cov.diagonal().array() += noise2_[s] + rel * rel;
    real factor = 1.0;
    std::uint8_t f = 0;
    if (max_speed_[s] > 0.0) {
      factor *= options_.speed_factor(predicted_speed, max_speed_[s]);
      if (predicted_speed >= options_.speed_onset * max_speed_[s]) f |= kNoiseOverSpeed;
      if (predicted_speed >= max_speed_[s]) f |= kNoiseOverRating;
    }
    if (sample.squal[s] < options_.min_squal) {
      factor *= options_.low_squal_factor;
      f |= kNoiseLowSqual;
    }
    if (sample.flags[s] & kFlagOverflow) {
      factor *= options_.overflow_factor;
      f |= kNoiseOverflow;
    }
    out.info[s] = (factor * cov).inverse();
    flags[s] = f;
  }
}

}  // namespace moa
