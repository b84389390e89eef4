// Errors of an estimated trajectory against ground truth.
//
// Truth is interpolated linearly in (x, y, theta) (theta unwrapped) at each
// estimate's time. Translation error = |p_est - p_truth| (m); heading error
// = |wrap(theta_est - theta_truth)| (rad). Max and RMS over the estimates
// that fall within the truth's time span. The distance travelled is the
// truth's path length from its first row to the last estimate compared, so
// an error can be read as a share of the way the robot went.
#pragma once

#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "moa/core/array.hpp"
#include "moa/core/se2.hpp"

namespace moa {

struct StampedPose {
  double t = 0.0;
  Pose2 pose;
};

/// Linear interpolation of a time-sorted trajectory; nullopt outside it.
std::optional<Pose2> interpolate(std::span<const StampedPose> trajectory, double t);

/// Length (m) of the polyline through the trajectory's positions between
/// times t0 and t1, the ends interpolated as interpolate() does and clamped
/// to the trajectory's span; 0 when t1 <= t0.
double path_length(std::span<const StampedPose> trajectory, double t0, double t1);

struct TrajectoryError {
  std::size_t samples = 0;       ///< estimates compared
  std::size_t outside = 0;       ///< estimates outside the truth's time span
  double max_translation = 0.0;  ///< m
  double rms_translation = 0.0;  ///< m
  double max_heading = 0.0;      ///< rad
  double rms_heading = 0.0;      ///< rad
  /// The error of the latest estimate compared (largest t; the last of equal t).
  double final_translation = 0.0;  ///< m
  double final_heading = 0.0;      ///< rad
  double distance = 0.0;  ///< m, truth's path length from its start to the last estimate compared
};

/// Calls f(name, value) for each member of `e` under the names of `moa
/// evaluate --json` (units in the names): samples, outside_truth_span,
/// distance_m, max_translation_m, rms_translation_m, max_heading_rad,
/// rms_heading_rad, final_translation_m, final_heading_rad. The one list of
/// them: the JSON of `moa evaluate` and of the experiments, and Python's dict.
template <class F>
void for_each_member(const TrajectoryError& e, F&& f) {
  f("samples", e.samples);
  f("outside_truth_span", e.outside);
  f("distance_m", e.distance);
  f("max_translation_m", e.max_translation);
  f("rms_translation_m", e.rms_translation);
  f("max_heading_rad", e.max_heading);
  f("rms_heading_rad", e.rms_heading);
  f("final_translation_m", e.final_translation);
  f("final_heading_rad", e.final_heading);
}

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
  double last_t_ = 0.0;
};

/// The error that count quantisation alone gives on the truth's path: what
/// an ideal array with these mounts would make. For each interval between
/// consecutive truth rows, each sensor's exact counts for the constant
/// twist joining the two poses (twist_between; a body-fixed point moves at
/// a constant body-frame velocity under it, so the counts are exact) are
/// added to its running total, which it reports rounded to whole counts,
/// the fraction carried to the next row as a real sensor does. The
/// least-squares twist of all sensors is integrated exactly from the
/// truth's first pose. Nullopt if the geometry cannot give a twist or the
/// truth has fewer than two rows or times that do not increase.
std::optional<TrajectoryError> quantisation_floor(const SensorArray& array,
                                                  std::span<const StampedPose> truth);

/// A run's max translation error set against a reference (both m).
struct ErrorReference {
  double max_translation = 0.0;  ///< m
  std::string label;             ///< e.g. "Sekimori & Miyazaki's Table 4"
  /// The reference is quantisation_floor()'s: the run is judged "at the
  /// floor" within kFloorTolerance times it (the floor is one realisation of
  /// the rounding; the run's own rounding falls differently).
  bool is_floor = false;
};
inline constexpr double kFloorTolerance = 2.0;

/// The translation error for a person: "max 15.4 mm over 2.5 m travelled
/// (0.62 %), rms 6.76 mm" (the share left out when the distance is 0).
std::string describe_translation(const TrajectoryError& error);

/// One line judging `error` against `reference`, with both figures in mm
/// and their ratio, e.g. "at the quantisation floor (0.015 mm, 1.0x its
/// 0.015 mm): exact up to the sensors' resolution".
std::string verdict(const TrajectoryError& error, const ErrorReference& reference);

}  // namespace moa
