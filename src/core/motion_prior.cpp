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

Mat3 MotionPrior::covariance(double t, real min_elapsed) const {
  const real e = std::max(static_cast<real>(t - t_), min_elapsed);
  const real v = limits_.accel * e, w = limits_.angular_accel * e;
  Mat3 p = covariance_;
  p.diagonal() += Vec3(v * v, v * v, w * w);
  return p;
}

}  // namespace moa
