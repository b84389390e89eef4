// The pose stream's line (`moa live --pose-out`, docs/formats/pose-stream.md):
// one JSON object per step, in REP-103's frames and units and
// nav_msgs/Odometry's split, so that a few lines of a robot's program (or
// examples/pose_bridge.py) put it on a ROS topic:
//
//   pose  world_T_robot in the odometry frame "odom" (x, y in m; theta in
//         rad, counter-clockwise from x about z up), with its 6x6 row-major
//         covariance over (x, y, z, roll, pitch, yaw) when the pipeline has
//         one (the EKF's, with camera fusion), else null;
//   twist in the robot frame "base_link" (x forward, y left; vx, vy in m/s,
//         omega in rad/s), with its 6x6 covariance over (vx, vy, vz, wx, wy,
//         wz) from the estimator's 3x3 over (vx, vy, omega).
//
// The planar entries (indices 0, 1, 5 of each axis) carry the 3x3; every
// other entry is 0: the model is planar (z, roll, pitch and their rates are
// zero by construction, not measured). Numbers are the shortest text that
// reads back as the same double (the same text as odometry.csv's), non-finite
// ones null.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "moa/core/odometry.hpp"

namespace moa::io {

class PoseLineWriter {
 public:
  /// `names`: the config's sensor names, by index.
  explicit PoseLineWriter(const std::vector<std::string>& names);
  /// The line of `step`, numbered `seq` (0, 1, ... for the lines a run
  /// made, sent or not: a gap tells the reader of lines lost), ending in
  /// '\n'. Valid until the next call.
  std::string_view format(const OdometryStep& step, std::uint64_t seq);

 private:
  std::vector<std::string> names_;
  std::vector<std::string> quoted_;  ///< names_ as JSON string literals
  std::string line_;
};

}  // namespace moa::io
