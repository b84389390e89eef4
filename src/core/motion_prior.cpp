#include "moa/core/motion_prior.hpp"

#include <algorithm>
#include <cmath>

namespace moa {

const char* RobotLimits::validate() const {
  if (!(std::isfinite(accel) && accel > 0.0))
    return "limits.accel: must be positive and finite (m/s^2)";
  if (!(std::isfinite(angular_accel) && angular_accel > 0.0))
    return "limits.angular_accel: must be positive and finite (rad/s^2)";
  return "";
}

Eigen::Matrix3d MotionPrior::covariance(double t, double min_elapsed) const {
  const double e = std::max(t - t_, min_elapsed);
  const double v = limits_.accel * e, w = limits_.angular_accel * e;
  Eigen::Matrix3d p = covariance_;
  p.diagonal() += Eigen::Vector3d(v * v, v * v, w * w);
  return p;
}

}  // namespace moa
