#include "moa/sim/camera.hpp"

#include <cmath>
#include <numbers>

namespace moa::sim {

CameraFix Camera::capture(double t, const Pose2& truth) {
  CameraFix fix;
  fix.t = t;
  fix.t_arrival = t + model_.latency;
  fix.sigma = model_.noise;
  fix.position = truth.t;
  fix.position.x() += model_.noise * rng_.normal();
  fix.position.y() += model_.noise * rng_.normal();
  if (model_.outlier_rate > 0.0 && rng_.uniform() < model_.outlier_rate) {
    const double angle = 2.0 * std::numbers::pi * rng_.uniform();
    fix.position += model_.outlier_magnitude * Eigen::Vector2d(std::cos(angle), std::sin(angle));
    fix.outlier = true;
  }
  return fix;
}

}  // namespace moa::sim
