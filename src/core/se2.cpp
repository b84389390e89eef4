#include "moa/core/se2.hpp"

#include <numbers>

namespace moa {

double wrap_angle(double angle) {
  double a = std::remainder(angle, 2.0 * std::numbers::pi);  // [-pi, pi]
  if (a <= -std::numbers::pi) a += 2.0 * std::numbers::pi;
  return a;
}

VTerms v_terms(double phi) {
  if (std::abs(phi) < kSmallAngle) {
    const double p2 = phi * phi;
    return {1.0 - p2 / 6.0 + p2 * p2 / 120.0, phi / 2.0 - phi * p2 / 24.0 + phi * p2 * p2 / 720.0,
            -phi / 3.0 + phi * p2 / 30.0, 0.5 - p2 / 8.0 + p2 * p2 / 144.0};
  }
  // 1 - cos(phi) = 2 sin^2(phi/2) avoids the cancellation that costs
  // (1 - cos(phi)) / phi about 1e-12 of accuracy near phi = 1e-4.
  const double sn = std::sin(phi), half = std::sin(phi / 2.0);
  const double s = sn / phi, c = 2.0 * half * half / phi;
  return {s, c, (std::cos(phi) - s) / phi, (sn - c) / phi};
}

Pose2 exp(const Twist2& twist, double dt) {
  const double phi = twist.omega * dt;
  const VTerms v = v_terms(phi);
  return {v_matrix(v.s, v.c) * twist.v * dt, phi};
}

Twist2 twist_between(const Pose2& from, const Pose2& to, double dt) {
  const Eigen::Vector2d d = rotation(-from.theta) * (to.t - from.t);
  const double phi = to.theta - from.theta;
  const VTerms v = v_terms(phi);
  const double n = v.s * v.s + v.c * v.c;
  const Eigen::Vector2d u((v.s * d.x() + v.c * d.y()) / n, (-v.c * d.x() + v.s * d.y()) / n);
  return {u / dt, phi / dt};
}

Pose2 integrate_exact(const Pose2& pose, const Twist2& twist, double dt) {
  return pose * exp(twist, dt);
}

Pose2 integrate_euler(const Pose2& pose, const Twist2& twist, double dt) {
  return {pose.t + rotation(pose.theta) * twist.v * dt, pose.theta + twist.omega * dt};
}

}  // namespace moa
