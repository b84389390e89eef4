// The motion prior of the robust estimators: the twist a robot can have now,
// given the last twist that was trusted and how hard the robot can
// accelerate.
//
// Constant-twist prediction in the robot frame with a random walk in
// acceleration: after an interval e (s) since the last trusted twist x0
// (covariance P0), the twist is x0 with covariance
//   P(e) = P0 + diag((a e)^2, (a e)^2, (alpha e)^2),
// a (m/s^2) and alpha (rad/s^2) the robot's linear and angular acceleration
// limits, taken as one standard deviation (a chi-square gate at 1e-3 then
// admits about four times the limit: a robot at its limit is never rejected,
// a count loss of 2 mm in 10 ms, 0.2 m/s in one epoch, is).
#pragma once

#include <Eigen/Core>

#include "moa/core/options_check.hpp"
#include "moa/core/se2.hpp"

namespace moa {

/// Robot limits (config key `limits`, docs/guide.md).
struct RobotLimits {
  real accel = 2.0;           ///< m/s^2, linear acceleration
  real angular_accel = 20.0;  ///< rad/s^2, angular acceleration
  /// nullopt when usable, else the first field out of its bounds, its path
  /// relative to this struct (options_check.hpp).
  OptionCheck validate() const;
};

class MotionPrior {
 public:
  explicit MotionPrior(RobotLimits limits = {}) : limits_(limits) {}

  /// Records a trusted twist at time t (s).
  void trust(const Twist2& twist, const Mat3& covariance, double t) {
    twist_ = twist;
    covariance_ = covariance;
    t_ = t;
    valid_ = true;
  }
  bool valid() const { return valid_; }
  const Twist2& twist() const { return twist_; }
  /// P(e) at time t, e = max(t - t_trusted, min_elapsed).
  Mat3 covariance(double t, real min_elapsed) const;
  const RobotLimits& limits() const { return limits_; }

 private:
  RobotLimits limits_;
  Twist2 twist_;
  Mat3 covariance_ = Mat3::Zero();
  double t_ = 0.0;
  bool valid_ = false;
};

}  // namespace moa
