// What the robust estimators fall back on when no set of sensors can be
// trusted: the wheel twist with its noise model, or the last good twist held.
#pragma once

#include <Eigen/Core>
#include <optional>

#include "moa/core/options_check.hpp"
#include "moa/core/robust_estimate.hpp"
#include "moa/core/se2.hpp"

namespace moa {

/// Covariance of a wheel-odometry twist: wheels slip, more when fast.
///   sd(v) = base_v + rel * |v|,  sd(omega) = base_omega + rel * |omega|.
struct WheelNoise {
  real base_v = 0.02;      ///< m/s
  real base_omega = 0.05;  ///< rad/s
  real relative = 0.1;
  Mat3 covariance(const Twist2& wheels) const;
  /// nullopt when usable, else the first field out of its bounds, its path
  /// relative to this struct (options_check.hpp).
  OptionCheck validate() const;
};

/// The twist to use when nothing can be trusted and there are no wheels:
/// the last good one, its covariance grown by a random walk in acceleration
/// (accel m/s^2, angular accel rad/s^2) over the time since it was good.
struct HoldModel {
  real accel = 1.0;
  real angular_accel = 5.0;
  Mat3 grown(const Mat3& covariance, real elapsed) const;
  /// nullopt when usable, else the first field out of its bounds, its path
  /// relative to this struct (options_check.hpp).
  OptionCheck validate() const;
};

/// What both robust estimators do when no set of sensors can be trusted:
/// the wheel twist (its covariance from WheelNoise), or without wheels the
/// last good twist held with its covariance grown (HoldModel).
class Fallback {
 public:
  /// Records a twist that came from the mice at time t.
  void good(const Twist2& twist, const Mat3& covariance, double t) {
    last_twist_ = twist;
    last_covariance_ = covariance;
    last_good_t_ = t;
  }
  /// Fills out's twist, covariance and source for a sample at time t.
  void apply(RobustEstimate& out, const std::optional<Twist2>& wheels,
             const WheelNoise& wheel_noise, const HoldModel& hold, double t);
  /// The best guess of the current twist (for predicting sensor speeds).
  const Twist2& last_twist() const { return last_twist_; }

 private:
  Twist2 last_twist_;
  Mat3 last_covariance_ = Mat3::Zero();
  double last_good_t_ = 0.0;
};

}  // namespace moa
