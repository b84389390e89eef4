// Errors of an estimated trajectory against ground truth.
//
// Truth is interpolated linearly in (x, y, theta) (theta unwrapped) at each
// estimate's time. Translation error = |p_est - p_truth| (m); heading error
// = |wrap(theta_est - theta_truth)| (rad). Max and RMS over the estimates
// that fall within the truth's time span.
#pragma once

#include <cstddef>
#include <optional>
#include <span>

#include "moa/core/se2.hpp"

namespace moa {

struct StampedPose {
  double t = 0.0;
  Pose2 pose;
};

/// Linear interpolation of a time-sorted trajectory; nullopt outside it.
std::optional<Pose2> interpolate(std::span<const StampedPose> trajectory, double t);

struct TrajectoryError {
  std::size_t samples = 0;       ///< estimates compared
  std::size_t outside = 0;       ///< estimates outside the truth's time span
  double max_translation = 0.0;  ///< m
  double rms_translation = 0.0;  ///< m
  double max_heading = 0.0;      ///< rad
  double rms_heading = 0.0;      ///< rad
};

/// Accumulates errors estimate by estimate (the estimates need not be kept).
class TrajectoryErrorAccumulator {
 public:
  explicit TrajectoryErrorAccumulator(std::span<const StampedPose> truth) : truth_(truth) {}
  void add(double t, const Pose2& estimate);
  TrajectoryError result() const;

 private:
  std::span<const StampedPose> truth_;
  TrajectoryError e_;
  double sum_sq_translation_ = 0.0;
  double sum_sq_heading_ = 0.0;
};

}  // namespace moa
