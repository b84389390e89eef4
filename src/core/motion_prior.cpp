#include "moa/core/motion_prior.hpp"

#include <algorithm>
#include <cmath>

namespace moa {

OptionCheck RobotLimits::validate() const {
  return OptionsCheck().positive("accel", accel).positive("angular_accel", angular_accel).result();
}

Mat3 MotionPrior::covariance(double t, real min_elapsed) const {
  const real e = std::max(static_cast<real>(t - t_), min_elapsed);
  const real v = limits_.accel * e, w = limits_.angular_accel * e;
  Mat3 p = covariance_;
  p.diagonal() += Vec3(v * v, v * v, w * w);
  return p;
}

}  // namespace moa
