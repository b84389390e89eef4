// Dead reckoning: the robot's pose from its twists, integrated exactly on
// SE(2) (Sekimori & Miyazaki eq. (6) is the first-order Euler step of it).
#pragma once

#include "moa/core/se2.hpp"

namespace moa {

/// Integrates twists into world_T_robot, exactly (SE(2) exponential).
class DeadReckoner {
 public:
  explicit DeadReckoner(const Pose2& initial = {}) : pose_(initial) {}
  const Pose2& step(const Twist2& twist, real dt) {
    pose_ = integrate_exact(pose_, twist, dt);
    return pose_;
  }
  const Pose2& pose() const { return pose_; }

 private:
  Pose2 pose_;
};

}  // namespace moa
