#include "moa/core/se2.hpp"

#include <numbers>

namespace moa {

real wrap_angle(real angle) {
  real a = std::remainder(angle, 2.0 * std::numbers::pi_v<real>);  // [-pi, pi]
  if (a <= -std::numbers::pi_v<real>) a += 2.0 * std::numbers::pi_v<real>;
  return a;
}

VTerms v_terms(real phi) {
  if (std::abs(phi) < kSmallAngle) {
    const real p2 = phi * phi;
    return {1.0 - p2 / 6.0 + p2 * p2 / 120.0, phi / 2.0 - phi * p2 / 24.0 + phi * p2 * p2 / 720.0,
            -phi / 3.0 + phi * p2 / 30.0, 0.5 - p2 / 8.0 + p2 * p2 / 144.0};
  }
  // 1 - cos(phi) = 2 sin^2(phi/2) avoids the cancellation that costs
  // (1 - cos(phi)) / phi about 1e-12 of accuracy near phi = 1e-4.
  const real sn = std::sin(phi), half = std::sin(phi / 2.0);
  const real s = sn / phi, c = 2.0 * half * half / phi;
  return {s, c, (std::cos(phi) - s) / phi, (sn - c) / phi};
}

namespace {
// s and c of v_terms() alone, by the same operations: exp() has no use for
// the derivatives, whose cos(phi) is a library call.
void v_terms_sc(real phi, real& s, real& c) {
  if (std::abs(phi) < kSmallAngle) {
    const real p2 = phi * phi;
    s = 1.0 - p2 / 6.0 + p2 * p2 / 120.0;
    c = phi / 2.0 - phi * p2 / 24.0 + phi * p2 * p2 / 720.0;
    return;
  }
  const real half = std::sin(phi / 2.0);
  s = std::sin(phi) / phi;
  c = 2.0 * half * half / phi;
}
}  // namespace

Pose2 exp(const Twist2& twist, real dt) {
  const real phi = twist.omega * dt;
  real s = 0.0, c = 0.0;
  v_terms_sc(phi, s, c);
  return {v_matrix(s, c) * twist.v * dt, phi};
}

Twist2 twist_between(const Pose2& from, const Pose2& to, real dt) {
  const Vec2 d = rotation(-from.theta) * (to.t - from.t);
  const real phi = to.theta - from.theta;
  const VTerms v = v_terms(phi);
  const real n = v.s * v.s + v.c * v.c;
  const Vec2 u((v.s * d.x() + v.c * d.y()) / n, (-v.c * d.x() + v.s * d.y()) / n);
  return {u / dt, phi / dt};
}

Pose2 integrate_exact(const Pose2& pose, const Twist2& twist, real dt) {
  return pose * exp(twist, dt);
}

Pose2 integrate_euler(const Pose2& pose, const Twist2& twist, real dt) {
  return {pose.t + rotation(pose.theta) * twist.v * dt, pose.theta + twist.omega * dt};
}

}  // namespace moa
