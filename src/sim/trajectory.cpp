#include "moa/sim/trajectory.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <numbers>

namespace moa::sim {
namespace {

// The smaller of a / b over the terms with b > 0 (a limit per unit of s).
double limit_per_unit(double limit_a, double amount_a, double limit_b, double amount_b) {
  double best = std::numeric_limits<double>::infinity();
  if (amount_a > 0.0) best = std::min(best, limit_a / amount_a);
  if (amount_b > 0.0) best = std::min(best, limit_b / amount_b);
  return best;
}

// sin^2 ramp from 0 at x = 0 to 1 at x = 1.
double ramp(double x) {
  const double s = std::sin(0.5 * std::numbers::pi * std::clamp(x, 0.0, 1.0));
  return s * s;
}

double sum_of_sines(const std::vector<Excitation::Sine>& sines, double t) {
  double sum = 0.0;
  for (const auto& s : sines) {
    sum += s.amplitude * std::sin(2.0 * std::numbers::pi * s.frequency * t + s.phase);
  }
  return sum;
}

}  // namespace

Trapezoid::Trapezoid(double max_rate, double max_accel) : accel_(max_accel) {
  assert(max_rate > 0.0 && max_accel > 0.0);
  accel_time_ = max_rate / max_accel;
  if (max_rate * accel_time_ >= 1.0) {
    // The two ramps alone cover more than the whole way: a triangle.
    accel_time_ = std::sqrt(1.0 / max_accel);
    peak_rate_ = max_accel * accel_time_;
    cruise_time_ = 0.0;
  } else {
    peak_rate_ = max_rate;
    cruise_time_ = (1.0 - max_rate * accel_time_) / max_rate;
  }
}

double Trapezoid::position(double t) const {
  const double total = duration();
  if (t <= 0.0) return 0.0;
  if (t >= total) return 1.0;
  if (t < accel_time_) return 0.5 * accel_ * t * t;
  if (t < accel_time_ + cruise_time_) {
    return 0.5 * accel_ * accel_time_ * accel_time_ + peak_rate_ * (t - accel_time_);
  }
  const double left = total - t;
  return 1.0 - 0.5 * accel_ * left * left;
}

WaypointPath::WaypointPath(std::vector<Pose2> waypoints, Interpolation interpolation,
                           PathLimits limits, double pause)
    : waypoints_(std::move(waypoints)), interpolation_(interpolation), pause_(pause) {
  assert(waypoints_.size() >= 2);
  double t = pause_;
  for (std::size_t i = 0; i + 1 < waypoints_.size(); ++i) {
    const Pose2& from = waypoints_[i];
    const Pose2& to = waypoints_[i + 1];
    Segment seg;
    seg.start = t;
    double length = 0.0;  // m per unit of s
    double angle = 0.0;   // rad per unit of s
    if (interpolation_ == Interpolation::kArc) {
      seg.body = twist_between(from, to, 1.0);
      length = seg.body.v.norm();
      angle = std::abs(seg.body.omega);
    } else {
      length = (to.t - from.t).norm();
      angle = std::abs(to.theta - from.theta);
    }
    if (length > 0.0 || angle > 0.0) {
      seg.profile =
          Trapezoid(limit_per_unit(limits.max_speed, length, limits.max_rate, angle),
                    limit_per_unit(limits.max_accel, length, limits.max_angular_accel, angle));
    }
    t += seg.profile.duration() + pause_;
    segments_.push_back(seg);
  }
  duration_ = t;
}

double WaypointPath::arrival_time(std::size_t i) const {
  if (i == 0) return 0.0;
  const Segment& seg = segments_[i - 1];
  return seg.start + seg.profile.duration();
}

Pose2 WaypointPath::pose(double t) const {
  // The last segment that has started by t.
  const auto it = std::upper_bound(segments_.begin(), segments_.end(), t,
                                   [](double time, const Segment& s) { return time < s.start; });
  if (it == segments_.begin()) return waypoints_.front();
  const std::size_t i = static_cast<std::size_t>(it - segments_.begin()) - 1;
  const Segment& seg = segments_[i];
  const double tau = t - seg.start;
  // At rest on a waypoint the pose is the waypoint itself, not a sum that
  // rounds near it: a path ends exactly where its table says.
  if (tau >= seg.profile.duration()) return waypoints_[i + 1];
  const double s = seg.profile.position(tau);
  const Pose2& from = waypoints_[i];
  const Pose2& to = waypoints_[i + 1];
  if (interpolation_ == Interpolation::kArc) return from * exp(seg.body, s);
  return {from.t + s * (to.t - from.t), from.theta + s * (to.theta - from.theta)};
}

double TwistProgram::duration() const {
  double total = 0.0;
  for (const auto& s : segments) total += s.duration;
  return total;
}

Twist2 TwistProgram::command(double t) const {
  double start = 0.0;
  for (const auto& s : segments) {
    if (t >= start && t < start + s.duration) return s.twist;
    start += s.duration;
  }
  return {};
}

Twist2 Excitation::twist(double t) const {
  if (t < 0.0 || t > duration) return {};
  double envelope = 1.0;
  if (fade > 0.0) envelope = ramp(t / fade) * ramp((duration - t) / fade);
  return {{envelope * (offset.v.x() + sum_of_sines(vx, t)),
           envelope * (offset.v.y() + sum_of_sines(vy, t))},
          envelope * (offset.omega + sum_of_sines(omega, t))};
}

double duration(const Motion& motion) {
  return std::visit(
      [](const auto& m) -> double {
        using T = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<T, Excitation>) {
          return m.duration;
        } else {
          return m.duration();
        }
      },
      motion);
}

MotionStepper::MotionStepper(const Motion& motion) : motion_(motion) {
  if (const auto* path = std::get_if<WaypointPath>(&motion_)) pose_ = path->waypoints().front();
}

MotionStepper::Step MotionStepper::advance(double t0, double t1) {
  const double h = t1 - t0;
  const double mid = 0.5 * (t0 + t1);
  if (const auto* path = std::get_if<WaypointPath>(&motion_)) {
    const Pose2 end = path->pose(t1);
    twist_ = twist_between(pose_, end, h);
    pose_ = end;
    return {twist_, pose_};
  }
  Twist2 next;
  if (const auto* program = std::get_if<TwistProgram>(&motion_)) {
    next = program->command(mid);
    if (program->max_accel > 0.0) {
      const Eigen::Vector2d dv = next.v - twist_.v;
      const double step = program->max_accel * h;
      if (dv.norm() > step) next.v = twist_.v + dv * (step / dv.norm());
    }
    if (program->max_angular_accel > 0.0) {
      const double step = program->max_angular_accel * h;
      next.omega = twist_.omega + std::clamp(next.omega - twist_.omega, -step, step);
    }
  } else {
    next = std::get<Excitation>(motion_).twist(mid);
  }
  twist_ = next;
  pose_ = integrate_exact(pose_, twist_, h);
  return {twist_, pose_};
}

}  // namespace moa::sim
