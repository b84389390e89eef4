#include "moa/se2.hpp"

#include <numbers>

namespace moa {

double wrap_angle(double angle) {
  double a = std::remainder(angle, 2.0 * std::numbers::pi);  // [-pi, pi]
  if (a <= -std::numbers::pi) a += 2.0 * std::numbers::pi;
  return a;
}

Pose2 exp(const Twist2& twist, double dt) {
  const double phi = twist.omega * dt;
  double s = 0.0;  // sin(phi) / phi
  double c = 0.0;  // (1 - cos(phi)) / phi
  if (std::abs(phi) < kSmallAngle) {
    const double phi2 = phi * phi;
    s = 1.0 - phi2 / 6.0 + phi2 * phi2 / 120.0;
    c = phi / 2.0 - phi * phi2 / 24.0 + phi * phi2 * phi2 / 720.0;
  } else {
    // 1 - cos(phi) = 2 sin^2(phi/2) avoids the cancellation that costs
    // (1 - cos(phi)) / phi about 1e-12 of accuracy near phi = 1e-4.
    const double half = std::sin(phi / 2.0);
    s = std::sin(phi) / phi;
    c = 2.0 * half * half / phi;
  }
  Eigen::Matrix2d v;
  v << s, -c, c, s;
  return {v * twist.v * dt, phi};
}

Pose2 integrate_exact(const Pose2& pose, const Twist2& twist, double dt) {
  return pose * exp(twist, dt);
}

Pose2 integrate_euler(const Pose2& pose, const Twist2& twist, double dt) {
  return {pose.t + rotation(pose.theta) * twist.v * dt, pose.theta + twist.omega * dt};
}

}  // namespace moa
