#include "moa/core/se2.hpp"

#include <cmath>
#include <numbers>

namespace moa {

real wrap_angle(real angle) {
  real a = std::remainder(angle, 2.0 * std::numbers::pi_v<real>);  // [-pi, pi]
  if (a <= -std::numbers::pi_v<real>) a += 2.0 * std::numbers::pi_v<real>;
  return a;
}

namespace {
// s = sin(phi)/phi and c = (1 - cos(phi))/phi, the one place of their
// Taylor series: exp() has no use for the derivatives, whose cos(phi) is a
// library call.
void v_terms_sc(real phi, real& s, real& c) {
  if (std::abs(phi) < kSmallAngle) {
    const real p2 = phi * phi;
    s = 1.0 - p2 / 6.0 + p2 * p2 / 120.0;
    c = phi / 2.0 - phi * p2 / 24.0 + phi * p2 * p2 / 720.0;
    return;
  }
  // 1 - cos(phi) = 2 sin^2(phi/2) avoids the cancellation that costs
  // (1 - cos(phi)) / phi about 1e-12 of accuracy near phi = 1e-4.
  const real half = std::sin(phi / 2.0);
  s = std::sin(phi) / phi;
  c = 2.0 * half * half / phi;
}
}  // namespace

VTerms v_terms(real phi) {
  VTerms v{};
  v_terms_sc(phi, v.s, v.c);
  if (std::abs(phi) < kSmallAngle) {
    // d/dphi of the series of s and c.
    const real p2 = phi * phi;
    v.ds = -phi / 3.0 + phi * p2 / 30.0;
    v.dc = 0.5 - p2 / 8.0 + p2 * p2 / 144.0;
    return v;
  }
  v.ds = (std::cos(phi) - v.s) / phi;
  v.dc = (std::sin(phi) - v.c) / phi;
  return v;
}

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

Mat3 exact_step_pose_jacobian(const Pose2& pose, const Twist2& twist, real dt) {
  const VTerms v = v_terms(twist.omega * dt);
  const Vec2 d = v_matrix(v.s, v.c) * twist.v * dt;
  Mat3 f = Mat3::Identity();
  f.block<2, 1>(0, 2) = rotation(pose.theta) * skew_unit() * d;
  return f;
}

Mat3 exact_step_twist_jacobian(const Pose2& pose, const Twist2& twist, real dt) {
  const VTerms v = v_terms(twist.omega * dt);
  const Mat2 r = rotation(pose.theta);
  Mat3 g = Mat3::Zero();
  g.block<2, 2>(0, 0) = r * v_matrix(v.s, v.c) * dt;
  g.block<2, 1>(0, 2) = r * v_matrix(v.ds, v.dc) * twist.v * dt * dt;
  g(2, 2) = dt;
  return g;
}

Pose2 integrate_euler(const Pose2& pose, const Twist2& twist, real dt) {
  return {pose.t + rotation(pose.theta) * twist.v * dt, pose.theta + twist.omega * dt};
}

}  // namespace moa
