#include "moa/core/fallback.hpp"

#include <cmath>

namespace moa {

OptionCheck WheelNoise::validate() const {
  return OptionsCheck()
      .positive("base_v", base_v)
      .positive("base_omega", base_omega)
      .non_negative("relative", relative)
      .result();
}

OptionCheck HoldModel::validate() const {
  return OptionsCheck().positive("accel", accel).positive("angular_accel", angular_accel).result();
}

Mat3 WheelNoise::covariance(const Twist2& wheels) const {
  const real sv = base_v + relative * wheels.v.norm();
  const real sw = base_omega + relative * std::abs(wheels.omega);
  return Vec3(sv * sv, sv * sv, sw * sw).asDiagonal();
}

Mat3 HoldModel::grown(const Mat3& covariance, real elapsed) const {
  const real v = accel * elapsed, w = angular_accel * elapsed;
  return covariance + Vec3(v * v, v * v, w * w).asDiagonal().toDenseMatrix();
}

void Fallback::apply(RobustEstimate& out, const std::optional<Twist2>& wheels,
                     const WheelNoise& wheel_noise, const HoldModel& hold, double t) {
  out.estimate.used = 0;
  if (wheels) {
    out.source = Source::kWheels;
    out.estimate.twist = *wheels;
    out.estimate.covariance = wheel_noise.covariance(*wheels);
    last_twist_ = *wheels;  // the best prediction of the sensors' speeds
  } else {
    out.source = Source::kHold;
    out.estimate.twist = last_twist_;
    out.estimate.covariance = hold.grown(last_covariance_, static_cast<real>(t - last_good_t_));
  }
}

}  // namespace moa
