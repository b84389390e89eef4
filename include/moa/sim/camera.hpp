// A simulated global (ceiling) camera: position-only fixes of the robot
// centre in the world frame, as in Sekimori & Miyazaki Section 4.3.
//
// A fix is captured every 1/rate s (rounded to whole sensor frames, the
// first at t = 0): p = p_true(t) + sigma n, n ~ N(0, I2); with probability
// `outlier_rate` a gross error of `outlier_magnitude` m in a uniformly random
// direction is added instead of nothing. It becomes available `latency`
// seconds after capture. camera.csv keeps the capture time in `t` (what a
// filter must use) and the arrival time in the extra column `t_arrival`
// (when a live system would have had it); sx = sy = sigma.
#pragma once

#include <Eigen/Core>

#include "moa/core/se2.hpp"
#include "moa/sim/random.hpp"

namespace moa::sim {

struct CameraModel {
  bool enabled = false;
  double rate = 10.0;              ///< fixes per second
  double noise = 0.005;            ///< m, std. dev. per axis
  double latency = 0.0;            ///< s, capture to arrival
  double outlier_rate = 0.0;       ///< probability that a fix is an outlier
  double outlier_magnitude = 0.0;  ///< m
};

struct CameraFix {
  double t = 0.0;          ///< s, capture time
  double t_arrival = 0.0;  ///< s
  Eigen::Vector2d position{0.0, 0.0};
  double sigma = 0.0;  ///< m
  bool outlier = false;
};

class Camera {
 public:
  Camera(const CameraModel& model, std::uint64_t seed)
      : model_(model), rng_(seed, Stream::kCamera) {}
  CameraFix capture(double t, const Pose2& truth);

 private:
  CameraModel model_;
  Rng rng_;
};

}  // namespace moa::sim
