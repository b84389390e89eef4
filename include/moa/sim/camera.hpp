// A simulated pose source: a ceiling camera (position-only fixes of the
// robot centre in the world frame, as in Sekimori & Miyazaki Section 4.3) or
// a motion-capture system (positions and heading).
//
// A fix is captured every round(frame_rate / rate) sensor frames, the first
// at t = 0: p = p_true(t) + sigma n, n ~ N(0, I2); in mode mocap also
// theta = wrap(theta_true(t) + sigma_theta n') (rad, in (-pi, pi]). With
// probability `outlier_rate` a gross error of `outlier_magnitude` m in a
// uniformly random direction is added to the position. A fix is lost with
// probability `drop` (independently per fix; its noise is drawn all the
// same, so drops change no other fix). A kept fix is stamped by its clock
// (clock.hpp): t = capture + latency + U[-jitter/2, +jitter/2], the time it
// reached the computer; sx = sy = sigma.
#pragma once

#include <Eigen/Core>
#include <optional>

#include "moa/core/se2.hpp"
#include "moa/sim/clock.hpp"
#include "moa/sim/random.hpp"

namespace moa::sim {

enum class CameraMode {
  kPositions,  ///< x, y: a ceiling camera
  kMocap,      ///< x, y, theta: motion capture
};

struct CameraModel {
  bool enabled = false;
  CameraMode mode = CameraMode::kPositions;
  double rate = 10.0;              ///< fixes per second
  double noise = 0.005;            ///< m, std. dev. per axis
  double heading_noise = 0.0;      ///< rad, std. dev. of theta (mode mocap)
  double latency = 0.0;            ///< s, stamp minus capture (mean)
  double jitter = 0.0;             ///< s, width of the stamps' uniform spread
  double drop = 0.0;               ///< probability that a fix is lost
  double outlier_rate = 0.0;       ///< probability that a fix is an outlier
  double outlier_magnitude = 0.0;  ///< m
};

struct CameraFix {
  double t = 0.0;          ///< s, capture time (true)
  double t_arrival = 0.0;  ///< s, the stamp: what camera.csv's t holds
  Eigen::Vector2d position{0.0, 0.0};
  std::optional<double> theta;  ///< rad, wrapped (mode mocap)
  double sigma = 0.0;           ///< m
  bool outlier = false;
};

class Camera {
 public:
  Camera(const CameraModel& model, std::uint64_t seed)
      : model_(model),
        rng_(seed, Stream::kCamera),
        drop_rng_(seed, Stream::kCameraDrop),
        clock_({model.latency, model.jitter}, seed, Stream::kCameraClock) {}
  /// The fix captured at `t` of the pose `truth`; nullopt if it is lost.
  std::optional<CameraFix> capture(double t, const Pose2& truth);

 private:
  CameraModel model_;
  Rng rng_;
  Rng drop_rng_;
  StreamClock clock_;
};

}  // namespace moa::sim
