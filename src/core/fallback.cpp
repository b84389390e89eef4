#include "moa/core/fallback.hpp"

#include <cmath>

namespace moa {

Eigen::Matrix3d WheelNoise::covariance(const Twist2& wheels) const {
  const double sv = base_v + relative * wheels.v.norm();
  const double sw = base_omega + relative * std::abs(wheels.omega);
  return Eigen::Vector3d(sv * sv, sv * sv, sw * sw).asDiagonal();
}

Eigen::Matrix3d HoldModel::grown(const Eigen::Matrix3d& covariance, double elapsed) const {
  const double v = accel * elapsed, w = angular_accel * elapsed;
  return covariance + Eigen::Vector3d(v * v, v * v, w * w).asDiagonal().toDenseMatrix();
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
    out.estimate.covariance = hold.grown(last_covariance_, t - last_good_t_);
  }
}

}  // namespace moa
