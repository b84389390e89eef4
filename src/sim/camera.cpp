#include "moa/sim/camera.hpp"

#include <cmath>
#include <numbers>

namespace moa::sim {

std::optional<CameraFix> Camera::capture(double t, const Pose2& truth) {
  CameraFix fix;
  fix.t = t;
  fix.sigma = model_.noise;
  fix.position = truth.t;
  fix.position.x() += model_.noise * rng_.normal();
  fix.position.y() += model_.noise * rng_.normal();
  if (model_.outlier_rate > 0.0 && rng_.uniform() < model_.outlier_rate) {
    const double angle = 2.0 * std::numbers::pi * rng_.uniform();
    fix.position += model_.outlier_magnitude * Eigen::Vector2d(std::cos(angle), std::sin(angle));
    fix.outlier = true;
  }
  if (model_.mode == CameraMode::kMocap) {
    // atan2(sin, cos): the heading wrapped into (-pi, pi].
    const double theta = truth.theta + model_.heading_noise * rng_.normal();
    fix.theta = std::atan2(std::sin(theta), std::cos(theta));
  }
  if (model_.drop > 0.0 && drop_rng_.uniform() < model_.drop) return std::nullopt;
  fix.t_arrival = clock_.stamp(t);
  return fix;
}

}  // namespace moa::sim
