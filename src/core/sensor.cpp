#include "moa/core/sensor.hpp"

namespace moa {

namespace {
Mat2 mirror(bool mirrored) { return Vec2(1.0, mirrored ? -1.0 : 1.0).asDiagonal(); }
}  // namespace

Mat2 SensorMount::counts_from_robot_velocity() const {
  return counts_per_metre() * scale.asDiagonal() * mirror(mirrored) * rotation(yaw).transpose();
}

Mat2 SensorMount::robot_velocity_from_counts() const {
  // Inverse of k S F R^T is R F S^-1 / k (F is its own inverse).
  const Vec2 inv_scale(1.0 / scale.x(), 1.0 / scale.y());
  return rotation(yaw) * mirror(mirrored) * inv_scale.asDiagonal() / counts_per_metre();
}

Vec2 corrected_counts(const SpeedScale& scale, const Mat2& velocity_from_counts,
                      const Vec2& counts, real dt) {
  if (!scale.active() || !(dt > 0)) return counts;
  // d = G^-1 counts (m, robot frame), c = |d| / dt (m/s); the counts are
  // G d, linear in d, so scaling d by 1 / ratio(s) scales the counts alike.
  const real counted_speed = (velocity_from_counts * counts).norm() / dt;
  return counts * scale.correction(counted_speed);
}

real impossible_speed(const SensorMount& mount) {
  return mount.max_speed ? kImpossibleSpeedFactor * *mount.max_speed : kImpossibleUnratedSpeed;
}

bool counts_impossible(const Mat2& velocity_from_counts, const Vec2& counts, real limit, real dt) {
#if defined(MOA_SCALAR_FLOAT)
  constexpr real kTiny = 1e-30f, kHuge = 1e30f, kClear = 1e-5f;
#else
  constexpr real kTiny = 1e-200, kHuge = 1e200, kClear = 1e-9;
#endif
  const Vec2 v = velocity_from_counts * counts;
  const real bound = limit * dt;
  const real n2 = v.squaredNorm(), l2 = bound * bound;
  if (l2 > kTiny && l2 < kHuge) {
    if (n2 < l2 * (1 - kClear)) return false;
    if (n2 > l2 * (1 + kClear)) return true;
  }
  return v.norm() > bound;
}

Mat<2, 3> SensorMount::point_jacobian() const {
  Mat<2, 3> a;
  a.leftCols<2>().setIdentity();
  a.col(2) = skew_unit() * position;
  return a;
}

Mat<2, 5> SensorMount::parameter_jacobian(const Twist2& twist) const {
  // counts/dt = k S F R(yaw)^T (v + omega J p)
  const Vec2 u = twist.v + twist.omega * skew_unit() * position;
  const Mat2 f = mirror(mirrored);
  const Mat2 rt = rotation(yaw).transpose();
  // d R(yaw)^T / d yaw = -J^T R^T... written directly: R(-yaw)' = -R(-yaw) J.
  const Mat2 drt = -rt * skew_unit();
  const Vec2 w = f * rt * u;  // mirrored sensor-frame velocity
  const real k = counts_per_metre();
  Mat<2, 5> d;
  d.leftCols<2>() = k * scale.asDiagonal() * f * rt * twist.omega * skew_unit();
  d.col(2) = k * scale.asDiagonal() * f * drt * u;
  d.col(3) = Vec2(k * w.x(), 0.0);
  d.col(4) = Vec2(0.0, k * w.y());
  return d;
}

}  // namespace moa
