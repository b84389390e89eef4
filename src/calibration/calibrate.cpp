#include "moa/calibration/calibrate.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>

namespace moa {

const char* describe(CalibrationError error) {
  switch (error) {
    case CalibrationError::kTooFewSensors:
      return "fewer than two sensors: calibration needs at least two";
    case CalibrationError::kTooManySensors:
      return "more sensors than moa::kMaxSensors, or samples that do not match the array";
    case CalibrationError::kInvalidMount:
      return "a nominal sensor has cpi or scale that is not positive and finite";
    case CalibrationError::kTooFewSamples:
      return "too few usable samples";
    case CalibrationError::kNoMotion:
      return "the reference twists are all zero: the robot did not move";
    case CalibrationError::kBadInput:
      return "unusable input";
  }
  return "calibration error";
}

const char* describe(MountParameter parameter) {
  switch (parameter) {
    case MountParameter::kPositionX:
      return "position x";
    case MountParameter::kPositionY:
      return "position y";
    case MountParameter::kYaw:
      return "yaw";
    case MountParameter::kScaleX:
      return "scale x";
    case MountParameter::kScaleY:
      return "scale y";
  }
  return "parameter";
}

MountVector mount_parameters(const SensorMount& mount) {
  MountVector x;
  x << mount.position.x(), mount.position.y(), mount.yaw, mount.scale.x(), mount.scale.y();
  return x;
}

SensorMount with_mount_parameters(SensorMount mount, const MountVector& parameters) {
  mount.position = parameters.head<2>();
  mount.yaw = parameters(2);
  mount.scale = parameters.tail<2>();
  return mount;
}

bool usable_sample(const CalibrationSample& sample, int n_sensors) {
  const ArraySample& m = sample.mice;
  if (m.size != n_sensors || !std::isfinite(m.dt) || !(m.dt > 0.0)) return false;
  if (!sample.reference.vector().allFinite()) return false;
  for (int i = 0; i < n_sensors; ++i) {
    const auto u = static_cast<std::size_t>(i);
    if (!m.counts[u].allFinite()) return false;
    if ((m.flags[u] & (kFlagLift | kFlagOverflow)) != 0) return false;
  }
  return true;
}

std::optional<CalibrationError> check_nominal(const SensorArray& nominal) {
  if (nominal.size() < 2) return CalibrationError::kTooFewSensors;
  if (nominal.size() > kMaxSensors) return CalibrationError::kTooManySensors;
  for (int i = 0; i < nominal.size(); ++i) {
    const SensorMount& m = nominal[i];
    const auto positive = [](double x) { return std::isfinite(x) && x > 0.0; };
    if (!positive(m.cpi) || !positive(m.scale.x()) || !positive(m.scale.y()) ||
        !m.position.allFinite() || !std::isfinite(m.yaw)) {
      return CalibrationError::kInvalidMount;
    }
  }
  return std::nullopt;
}

std::vector<CalibrationSample> merge_samples(const std::vector<CalibrationSample>& samples,
                                             int groups) {
  if (groups <= 0 || static_cast<std::size_t>(groups) >= samples.size()) return samples;
  double total = 0.0;
  for (const auto& s : samples) total += s.mice.dt;
  std::vector<CalibrationSample> out;
  CalibrationSample acc;
  Eigen::Vector3d twist_dt = Eigen::Vector3d::Zero();
  bool open = false;
  double done = 0.0;  // duration of the samples merged so far
  for (const auto& s : samples) {
    if (!open) {
      acc = s;
      acc.mice.dt = 0.0;
      for (int i = 0; i < s.mice.size; ++i) acc.mice.counts[static_cast<std::size_t>(i)].setZero();
      twist_dt.setZero();
      open = true;
    }
    for (int i = 0; i < s.mice.size; ++i) {
      const auto u = static_cast<std::size_t>(i);
      acc.mice.counts[u] += s.mice.counts[u];
      acc.mice.squal[u] = std::min(acc.mice.squal[u], s.mice.squal[u]);
      acc.mice.flags[u] |= s.mice.flags[u];
    }
    acc.mice.dt += s.mice.dt;
    acc.mice.t = s.mice.t;
    twist_dt += s.reference.vector() * s.mice.dt;
    done += s.mice.dt;
    // Close the group once it reaches its share of the total duration.
    const double target = total * static_cast<double>(out.size() + 1) / groups;
    if (done >= target - 1e-9 * total) {
      acc.reference = Twist2::from_vector(twist_dt / acc.mice.dt);
      out.push_back(acc);
      open = false;
    }
  }
  if (open) {
    acc.reference = Twist2::from_vector(twist_dt / acc.mice.dt);
    out.push_back(acc);
  }
  return out;
}

std::optional<SensorMatrixParts> decompose_sensor_matrix(const Eigen::Matrix2d& m,
                                                         double counts_per_metre) {
  const double k = counts_per_metre;
  const double det = m.determinant();
  if (!m.allFinite() || !(std::abs(det) > 1e-12 * k * k)) return std::nullopt;
  SensorMatrixParts parts;
  parts.mirrored = det < 0.0;
  // n = diag(1, f) M / k = diag(sx, sy) R(yaw)^T has det > 0; the rotation
  // nearest to a 2x2 matrix [[a, b], [c, d]] is that of ((a + d), (b - c)).
  Eigen::Matrix2d n = m / k;
  if (parts.mirrored) n.row(1) *= -1.0;
  const double cos_part = n(0, 0) + n(1, 1);
  const double sin_part = n(0, 1) - n(1, 0);
  parts.yaw = std::atan2(sin_part, cos_part);
  const Eigen::Vector2d row_x(std::cos(parts.yaw), std::sin(parts.yaw));
  const Eigen::Vector2d row_y(-std::sin(parts.yaw), std::cos(parts.yaw));
  parts.scale = {n.row(0).dot(row_x), n.row(1).dot(row_y)};
  return parts;
}

Eigen::Vector2d position_from_rotation_response(const Eigen::Matrix2d& m,
                                                const Eigen::Vector2d& q) {
  // J^-1 = -J.
  return -(skew_unit() * m.inverse() * q);
}

IntervalAccumulator::IntervalAccumulator(int n_sensors, double t0, std::vector<double> times,
                                         double max_row_interval)
    : n_(n_sensors),
      t0_(t0),
      max_row_interval_(max_row_interval),
      times_(std::move(times)),
      last_t_(static_cast<std::size_t>(n_sensors), t0),
      last_row_t_(t0) {
  const std::size_t m = times_.size() < 2 ? 0 : times_.size() - 1;
  samples_.resize(m);
  for (std::size_t k = 0; k < m; ++k) {
    ArraySample& s = samples_[k];
    s.t = times_[k + 1];
    s.dt = times_[k + 1] - times_[k];
    s.size = n_;
    for (int i = 0; i < n_; ++i) {
      const auto u = static_cast<std::size_t>(i);
      s.counts[u].setZero();
      s.squal[u] = 255;
      s.flags[u] = 0;
    }
  }
}

std::optional<RowError> IntervalAccumulator::add(const SensorRow& row) {
  if (auto error = check_row(row, n_, t0_, last_row_t_)) return error;

  const auto i = static_cast<std::size_t>(row.sensor);
  const double a = std::max(last_t_[i], row.t - max_row_interval_);
  const double b = row.t;
  last_t_[i] = b;
  last_row_t_ = b;
  if (samples_.empty()) return std::nullopt;

  const auto deposit = [&](std::size_t k, double fraction) {
    ArraySample& s = samples_[k];
    s.counts[i] += fraction * row.counts;
    if (row.squal) s.squal[i] = std::min(s.squal[i], *row.squal);
    s.flags[i] |= row.flags;
  };
  // Interval k (0-based) is (times_[k], times_[k + 1]].
  const auto interval_of = [&](double t) -> std::optional<std::size_t> {
    if (!(t > times_.front()) || t > times_.back()) return std::nullopt;
    const auto it = std::lower_bound(times_.begin(), times_.end(), t);
    return static_cast<std::size_t>(it - times_.begin()) - 1;
  };
  if (!(b > a)) {
    if (const auto k = interval_of(b)) deposit(*k, 1.0);
    return std::nullopt;
  }
  // First interval whose end is after a.
  auto it = std::upper_bound(times_.begin(), times_.end(), a);
  if (it == times_.begin()) ++it;
  for (; it != times_.end() && *(it - 1) < b; ++it) {
    const double overlap = std::min(b, *it) - std::max(a, *(it - 1));
    if (overlap > 0.0) {
      deposit(static_cast<std::size_t>(it - times_.begin()) - 1, overlap / (b - a));
    }
  }
  return std::nullopt;
}

std::vector<IntervalAccumulator::Interval> IntervalAccumulator::covered() const {
  std::vector<Interval> out;
  for (std::size_t k = 0; k < samples_.size(); ++k) {
    if (times_[k] >= t0_ && times_[k + 1] <= last_row_t_) {
      out.push_back({static_cast<int>(k), samples_[k]});
    }
  }
  return out;
}

}  // namespace moa
