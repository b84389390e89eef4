#include "moa/analysis/evaluate.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <variant>

#include "moa/core/estimate.hpp"

namespace moa {

std::optional<Pose2> interpolate(std::span<const StampedPose> trajectory, double t) {
  if (trajectory.empty() || t < trajectory.front().t || t > trajectory.back().t)
    return std::nullopt;
  const auto after = std::lower_bound(trajectory.begin(), trajectory.end(), t,
                                      [](const StampedPose& s, double time) { return s.t < time; });
  if (after->t == t || after == trajectory.begin()) return after->pose;
  const StampedPose& a = *(after - 1);
  const StampedPose& b = *after;
  const double f = (t - a.t) / (b.t - a.t);
  return Pose2{a.pose.t + f * (b.pose.t - a.pose.t),
               a.pose.theta + f * (b.pose.theta - a.pose.theta)};
}

double path_length(std::span<const StampedPose> trajectory, double t0, double t1) {
  if (trajectory.empty()) return 0.0;
  t0 = std::max(t0, trajectory.front().t);
  t1 = std::min(t1, trajectory.back().t);
  if (!(t1 > t0)) return 0.0;
  Eigen::Vector2d previous = interpolate(trajectory, t0)->t;
  double length = 0.0;
  for (const StampedPose& s : trajectory) {
    if (s.t <= t0) continue;
    if (s.t >= t1) break;
    length += (s.pose.t - previous).norm();
    previous = s.pose.t;
  }
  return length + (interpolate(trajectory, t1)->t - previous).norm();
}

void TrajectoryErrorAccumulator::add(double t, const Pose2& estimate) {
  const auto truth = interpolate(truth_, t);
  if (!truth) {
    ++e_.outside;
    return;
  }
  const double dp = (estimate.t - truth->t).norm();
  const double dh = std::abs(wrap_angle(estimate.theta - truth->theta));
  if (e_.samples == 0 || t >= last_t_) {
    e_.final_translation = dp;
    e_.final_heading = dh;
  }
  ++e_.samples;
  last_t_ = std::max(last_t_, t);
  e_.max_translation = std::max(e_.max_translation, dp);
  e_.max_heading = std::max(e_.max_heading, dh);
  sum_sq_translation_ += dp * dp;
  sum_sq_heading_ += dh * dh;
}

TrajectoryError TrajectoryErrorAccumulator::result() const {
  TrajectoryError out = e_;
  if (out.samples > 0) {
    const auto n = static_cast<double>(out.samples);
    out.rms_translation = std::sqrt(sum_sq_translation_ / n);
    out.rms_heading = std::sqrt(sum_sq_heading_ / n);
    out.distance = path_length(truth_, truth_.front().t, last_t_);
  }
  return out;
}

std::optional<TrajectoryError> quantisation_floor(const SensorArray& array,
                                                  std::span<const StampedPose> truth) {
  if (truth.size() < 2) return std::nullopt;
  const double reference_dt =
      (truth.back().t - truth.front().t) / static_cast<double>(truth.size() - 1);
  if (!(reference_dt > 0.0)) return std::nullopt;
  const auto created = LsEstimator::create(array, all_sensors(array.size()), reference_dt);
  const auto* ls = std::get_if<LsEstimator>(&created);
  if (ls == nullptr) return std::nullopt;

  const auto n = static_cast<std::size_t>(array.size());
  std::array<Eigen::Vector2d, kMaxSensors> exact = zeros<Eigen::Vector2d>();     // running totals
  std::array<Eigen::Vector2d, kMaxSensors> reported = zeros<Eigen::Vector2d>();  // whole counts
  TrajectoryErrorAccumulator acc(truth);
  Pose2 pose = truth.front().pose;
  for (std::size_t k = 1; k < truth.size(); ++k) {
    const double dt = truth[k].t - truth[k - 1].t;
    if (!(dt > 0.0)) return std::nullopt;
    const Twist2 twist = twist_between(truth[k - 1].pose, truth[k].pose, dt);
    ArraySample sample;
    sample.t = truth[k].t;
    sample.dt = dt;
    sample.size = array.size();
    for (std::size_t i = 0; i < n; ++i) {
      exact[i] += array.mounts()[i].counts(twist, dt);
      const Eigen::Vector2d rounded = exact[i].array().round().matrix();
      sample.counts[i] = rounded - reported[i];
      reported[i] = rounded;
    }
    const auto estimate = ls->estimate(sample);
    if (!estimate) return std::nullopt;
    pose = integrate_exact(pose, estimate->twist, dt);
    acc.add(truth[k].t, pose);
  }
  return acc.result();
}

namespace {
// `digits` significant digits in plain notation: 1100, not 1.1e+03.
std::string plain(double x, int digits) {
  if (std::abs(x) >= std::pow(10.0, digits)) return fmt::format("{:.0f}", x);
  return fmt::format("{:.{}g}", x, digits);
}
}  // namespace

std::string describe_translation(const TrajectoryError& error) {
  const std::string share =
      error.distance > 0.0
          ? fmt::format(" ({} %)", plain(100.0 * error.max_translation / error.distance, 2))
          : "";
  return fmt::format("max {} mm over {} m travelled{}, rms {} mm",
                     plain(error.max_translation * 1e3, 3), plain(error.distance, 3), share,
                     plain(error.rms_translation * 1e3, 3));
}

std::string verdict(const TrajectoryError& error, const ErrorReference& reference) {
  const double err_mm = error.max_translation * 1e3;
  const double ref_mm = reference.max_translation * 1e3;
  if (!(reference.max_translation > 0.0)) {  // every row held whole counts
    return fmt::format("max {:.3g} mm against {} of 0 mm", err_mm, reference.label);
  }
  const double ratio = error.max_translation / reference.max_translation;
  // Two significant digits, whole numbers from 100 on: "0.75x", "15x", "273x".
  const std::string times =
      ratio < 100.0 ? fmt::format("{:.2g}x", ratio) : fmt::format("{:.0f}x", ratio);
  if (reference.is_floor) {
    if (ratio <= kFloorTolerance) {
      return fmt::format(
          "at the quantisation floor (max {:.3g} mm, {} the {:.3g} mm that rounding to whole "
          "counts alone gives on this path): exact up to the sensors' resolution",
          err_mm, times, ref_mm);
    }
    return fmt::format(
        "{} the quantisation floor ({:.3g} mm against {:.3g} mm from rounding to whole counts "
        "alone): the rest comes from noise, faults or mounting errors, not from resolution",
        times, err_mm, ref_mm);
  }
  return fmt::format("{} {}'s {:.3g} mm (max {:.3g} mm, {})", ratio <= 1.0 ? "within" : "above",
                     reference.label, ref_mm, err_mm, times);
}

}  // namespace moa
