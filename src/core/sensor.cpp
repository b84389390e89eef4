#include "moa/core/sensor.hpp"

namespace moa {

namespace {
Eigen::Matrix2d mirror(bool mirrored) {
  return Eigen::Vector2d(1.0, mirrored ? -1.0 : 1.0).asDiagonal();
}
}  // namespace

Eigen::Matrix2d SensorMount::counts_from_robot_velocity() const {
  return counts_per_metre() * scale.asDiagonal() * mirror(mirrored) * rotation(yaw).transpose();
}

Eigen::Matrix2d SensorMount::robot_velocity_from_counts() const {
  // Inverse of k S F R^T is R F S^-1 / k (F is its own inverse).
  const Eigen::Vector2d inv_scale(1.0 / scale.x(), 1.0 / scale.y());
  return rotation(yaw) * mirror(mirrored) * inv_scale.asDiagonal() / counts_per_metre();
}

Eigen::Matrix<double, 2, 3> SensorMount::point_jacobian() const {
  Eigen::Matrix<double, 2, 3> a;
  a.leftCols<2>().setIdentity();
  a.col(2) = skew_unit() * position;
  return a;
}

Eigen::Matrix<double, 2, 5> SensorMount::parameter_jacobian(const Twist2& twist) const {
  // counts/dt = k S F R(yaw)^T (v + omega J p)
  const Eigen::Vector2d u = twist.v + twist.omega * skew_unit() * position;
  const Eigen::Matrix2d f = mirror(mirrored);
  const Eigen::Matrix2d rt = rotation(yaw).transpose();
  // d R(yaw)^T / d yaw = -J^T R^T... written directly: R(-yaw)' = -R(-yaw) J.
  const Eigen::Matrix2d drt = -rt * skew_unit();
  const Eigen::Vector2d w = f * rt * u;  // mirrored sensor-frame velocity
  const double k = counts_per_metre();
  Eigen::Matrix<double, 2, 5> d;
  d.leftCols<2>() = k * scale.asDiagonal() * f * rt * twist.omega * skew_unit();
  d.col(2) = k * scale.asDiagonal() * f * drt * u;
  d.col(3) = Eigen::Vector2d(k * w.x(), 0.0);
  d.col(4) = Eigen::Vector2d(0.0, k * w.y());
  return d;
}

}  // namespace moa
