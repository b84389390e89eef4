// Rigid motions of the plane: poses, twists and their integration.
//
// Conventions (all frames right-handed, angles counter-clockwise, SI units):
//   Pose2 world_T_robot maps robot-frame points into the world frame:
//     p_world = R(theta) * p_robot + t.
//   theta is kept unwrapped so that a heading trace can be plotted and
//   differenced without jumps; wrap only where an angle is compared.
//   Twist2 (v, omega) is the robot's velocity expressed in its own frame:
//     v = (vx, vy) in m/s, omega in rad/s.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <numbers>

#include "moa/core/real.hpp"

namespace moa {

/// J = [[0,-1],[1,0]]: rotation by +90 deg; omega x p = omega * J * p in 2-D.
inline Mat2 skew_unit() {
  Mat2 j;
  j << 0.0, -1.0, 1.0, 0.0;
  return j;
}

/// R(a) = [[cos a, -sin a], [sin a, cos a]].
inline Mat2 rotation(real angle) {
  const real c = std::cos(angle);
  const real s = std::sin(angle);
  Mat2 r;
  r << c, -s, s, c;
  return r;
}

/// Wraps an angle to (-pi, pi].
real wrap_angle(real angle);

/// Degrees of an angle in radians (x 180/pi), and radians of one in degrees:
/// the one conversion of every display and input in degrees.
constexpr double to_degrees(double radians) { return radians * (180.0 / std::numbers::pi); }
constexpr double to_radians(double degrees) { return degrees * (std::numbers::pi / 180.0); }

/// Robot velocity in the robot frame.
struct Twist2 {
  Vec2 v{0.0, 0.0};  ///< m/s, robot frame
  real omega = 0.0;  ///< rad/s

  /// (vx, vy, omega), the ordering used by every 3-vector and 3x3 covariance.
  Vec3 vector() const { return {v.x(), v.y(), omega}; }
  static Twist2 from_vector(const Vec3& x) { return {{x(0), x(1)}, x(2)}; }
};

/// An element of SE(2): a planar pose.
struct Pose2 {
  Vec2 t{0.0, 0.0};  ///< m
  real theta = 0.0;  ///< rad, unwrapped

  /// a * b: first b, then a (world_T_b = world_T_a * a_T_b).
  Pose2 operator*(const Pose2& b) const { return {t + rotation(theta) * b.t, theta + b.theta}; }
  /// Maps a point of this pose's frame into the parent frame.
  Vec2 operator*(const Vec2& p) const { return rotation(theta) * p + t; }
  Pose2 inverse() const { return {-(rotation(-theta) * t), -theta}; }
};

/// Below this |omega * dt| (rad) exp() uses the Taylor series of sin(a)/a and
/// (1 - cos a)/a; at 1e-4 the truncation error of three terms is ~1e-22.
inline constexpr real kSmallAngle = 1e-4;

/// The coefficients of V(phi) = [[s, -c], [c, s]] that exp() and its
/// Jacobians use: s = sin(phi)/phi, c = (1 - cos(phi))/phi and their
/// derivatives ds, dc in phi; Taylor series below kSmallAngle.
struct VTerms {
  real s, c, ds, dc;
};
VTerms v_terms(real phi);

/// [[s, -c], [c, s]].
inline Mat2 v_matrix(real s, real c) {
  Mat2 v;
  v << s, -c, c, s;
  return v;
}

/// Exact motion over dt of a body moving with a constant twist (the SE(2)
/// exponential map of twist * dt):
///   phi = omega dt,  t = V(phi) v dt,  V = [[s, -c], [c, s]],
///   s = sin(phi)/phi,  c = (1 - cos(phi))/phi.
Pose2 exp(const Twist2& twist, real dt);

/// The constant twist that carries `from` to `to` in dt seconds, the inverse
/// of exp (the SE(2) logarithm of from^-1 to, over dt): with
/// d = R(-theta_from)(t_to - t_from) and phi = theta_to - theta_from,
///   v = V(phi)^-1 d / dt,  omega = phi / dt,
///   V^-1 = [[s, c], [-c, s]] / (s^2 + c^2).
/// Valid for |phi| < 2 pi.
Twist2 twist_between(const Pose2& from, const Pose2& to, real dt);

/// world_T_robot after dt of constant twist, integrated exactly:
/// pose * exp(twist, dt).
Pose2 integrate_exact(const Pose2& pose, const Twist2& twist, real dt);

/// d pose' / d pose (3x3) of pose' = integrate_exact(pose, twist, dt), pose
/// as (x, y, theta) with theta additive:
///   [[I, R(theta) J d], [0, 1]],  d = V(phi) v dt,  J = [[0, -1], [1, 0]].
Mat3 exact_step_pose_jacobian(const Pose2& pose, const Twist2& twist, real dt);
/// d pose' / d twist (3x3) of integrate_exact(pose, twist, dt), twist as
/// (vx, vy, omega):
///   [[R(theta) V(phi) dt, R(theta) V'(phi) v dt^2], [0, 0, dt]],
///   V' = [[ds, -dc], [dc, ds]] (v_terms()).
Mat3 exact_step_twist_jacobian(const Pose2& pose, const Twist2& twist, real dt);

/// The first-order step of Sekimori & Miyazaki eq. (6): the displacement
/// (v dt) is rotated by the heading at the start of the step,
///   X_t = X_{t-1} + R(Theta_{t-1}) v dt,  Theta_t = Theta_{t-1} + omega dt.
/// Its position error per step is O(omega v dt^2), so O(dt) over a fixed time.
Pose2 integrate_euler(const Pose2& pose, const Twist2& twist, real dt);

}  // namespace moa
