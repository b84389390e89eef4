#include "moa/sim/wheels.hpp"

#include <Eigen/LU>
#include <cassert>
#include <cmath>

namespace moa::sim {

int DriveModel::wheel_count() const {
  switch (type) {
    case DriveType::kOmni3:
      return 3;
    case DriveType::kDifferential:
      return 2;
    case DriveType::kMecanum:
      return 4;
    case DriveType::kNone:
    case DriveType::kReference:
      break;
  }
  return 0;
}

WheelOdometry::WheelOdometry(const DriveModel& model, std::uint64_t seed)
    : model_(model), rng_(seed, Stream::kWheels) {
  if (model_.type == DriveType::kOmni3) {
    assert(model_.wheel_angles.size() == 3);
    const double r = model_.wheel_distance;
    for (int j = 0; j < 3; ++j) {
      const double a = model_.wheel_angles[static_cast<std::size_t>(j)];
      kinematics_.row(j) << -std::sin(a), std::cos(a), r;
    }
    forward_.leftCols<3>() = kinematics_.topRows<3>().inverse();
  } else if (model_.type == DriveType::kDifferential) {
    const double b = model_.wheel_distance;
    kinematics_.row(0) << 1.0, 0.0, -b;  // left wheel at (0, +b)
    kinematics_.row(1) << 1.0, 0.0, b;   // right wheel at (0, -b)
    forward_.col(0) << 0.5, 0.0, -0.5 / b;
    forward_.col(1) << 0.5, 0.0, 0.5 / b;
  } else if (model_.type == DriveType::kMecanum) {
    const double l = model_.wheel_distance;
    kinematics_.row(0) << 1.0, -1.0, -l;  // front left
    kinematics_.row(1) << 1.0, 1.0, l;    // front right
    kinematics_.row(2) << 1.0, 1.0, -l;   // rear left
    kinematics_.row(3) << 1.0, -1.0, l;   // rear right
    // (W^T W)^-1 W^T: W's columns are orthogonal, W^T W = diag(4, 4, 4 l^2).
    const Eigen::Matrix3d normal = kinematics_.transpose() * kinematics_;
    forward_ = normal.inverse() * kinematics_.transpose();
  }
  model_.slip.base.resize(kMaxWheels, 0.0);
}

// Per frame, on scalars (see OpticalSensor::frame for why).
void WheelOdometry::frame(const Twist2& twist, double h) {
  const double vx = twist.v.x();
  const double vy = twist.v.y();
  const double w = twist.omega;
  if (model_.type == DriveType::kReference) {
    reference_[0] += vx * h;
    reference_[1] += vy * h;
    reference_[2] += w * h;
    return;
  }
  const int n = model_.wheel_count();
  const SlipModel& slip = model_.slip;
  const double mid = t_ + 0.5 * h;
  t_ += h;
  Wheels burst = Wheels::Zero();
  for (const SlipBurst& b : slip.bursts) {
    if (mid < b.start || mid >= b.end) continue;
    for (int j = 0; j < n; ++j) {
      if (b.wheel < 0 || b.wheel == j) burst[j] += b.slip;
    }
  }
  const double decay = h / slip.random_time;
  const double kick = slip.random * std::sqrt(2.0 * decay);
  for (int j = 0; j < n; ++j) {
    const double g = kinematics_(j, 0) * vx + kinematics_(j, 1) * vy + kinematics_(j, 2) * w;
    const double accel = (g - ground_prev_[j]) / h;
    ground_prev_[j] = g;
    if (slip.random > 0.0) {
      // Ornstein-Uhlenbeck: stationary std. dev. `random`, correlation time tau.
      random_slip_[j] += -random_slip_[j] * decay + kick * rng_.normal();
    }
    const double fraction = slip.base[static_cast<std::size_t>(j)] + slip.per_speed * std::abs(g) +
                            random_slip_[j] + burst[j];
    travelled_[j] += (g * (1.0 + fraction) + slip.per_accel * accel) * h;
  }
}

Twist2 WheelOdometry::take_row(double dt) {
  Eigen::Vector3d x;
  if (model_.type == DriveType::kReference) {
    x = reference_ / dt;
    reference_.setZero();
  } else {
    Wheels counted = travelled_;
    if (model_.encoder_resolution > 0.0) {
      counted =
          (travelled_ / model_.encoder_resolution).array().round() * model_.encoder_resolution;
    }
    x = forward_ * (counted - reported_) / dt;
    reported_ = counted;
  }
  if (model_.noise_speed > 0.0) {
    x.x() += model_.noise_speed * rng_.normal();
    // A differential drive has no lateral wheel: its odometry says vy = 0.
    if (model_.type != DriveType::kDifferential) x.y() += model_.noise_speed * rng_.normal();
  }
  if (model_.noise_rate > 0.0) x.z() += model_.noise_rate * rng_.normal();
  return Twist2::from_vector(x);
}

}  // namespace moa::sim
