#include "moa/analysis/evaluate.hpp"

#include <algorithm>
#include <cmath>

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

void TrajectoryErrorAccumulator::add(double t, const Pose2& estimate) {
  const auto truth = interpolate(truth_, t);
  if (!truth) {
    ++e_.outside;
    return;
  }
  const double dp = (estimate.t - truth->t).norm();
  const double dh = std::abs(wrap_angle(estimate.theta - truth->theta));
  ++e_.samples;
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
  }
  return out;
}

}  // namespace moa
