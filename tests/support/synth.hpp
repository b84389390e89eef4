// Noise-free logs with known truth, for tests and the shipped example log.
//
// The robot follows a scripted twist x(t) = (vx, vy, omega)(t). Truth is
// integrated with exact SE(2) steps of `substep` seconds at the midpoint
// twist. Each sensor's real-valued counts are the integral of its
// body-fixed count rate G_i A_i x(t) (the measurement model), summed over
// the same substeps; a row's integer counts are round(C(t_k)) -
// round(C(t_{k-1})) of the cumulative count C, so the fraction is carried
// and the rows never drift from the truth by more than half a count.
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "moa/analysis/evaluate.hpp"
#include "moa/core/array.hpp"
#include "moa/core/se2.hpp"

namespace moa::test {

using TwistScript = std::function<Twist2(double t)>;

struct SynthRow {
  double t;
  int sensor;
  Eigen::Vector2d counts;  ///< integer-valued after quantisation
};

struct SynthLog {
  std::vector<StampedPose> truth;  ///< at every row time, from t = 0
  std::vector<SynthRow> rows;      ///< every sensor at every row time, time-sorted
};

/// Simulates `duration` s with rows every `row_period` s (a zero row for
/// each sensor at t = 0). `quantise` false keeps the real-valued counts.
SynthLog synthesise(const SensorArray& array, const TwistScript& script, double duration,
                    double row_period, bool quantise = true, double substep = 1e-4);

/// One epoch (t - dt, t] of noise-free real-valued counts: sensor i reads
/// `gain(i)` times its true point velocity under `twist` (robot frame: a
/// matrix such as g R(-d), or a scalar times the identity), SQUAL 90.
ArraySample exact_sample(const SensorArray& array, const Twist2& twist, double t, double dt,
                         const std::function<Mat2(int)>& gain);

/// A 20 s mixed motion for an omnidirectional robot: forward, lateral and
/// turning at once, all three changing sign (speeds up to ~0.35 m/s, 1 rad/s).
Twist2 mixed_motion(double t);

/// An array with yaw, per-axis scale and one mirrored sensor (4 sensors).
SensorArray skewed_array();

/// Writes mice.csv and truth.csv into `dir` (created if needed) and, when
/// `names` match the array, robot.yaml through the config writer.
void write_log(const SynthLog& log, const SensorArray& array, const std::vector<std::string>& names,
               const std::filesystem::path& dir);

/// A fresh empty directory under the system temp dir, named after `tag`;
/// removed with its contents when the test program ends.
std::filesystem::path scratch_dir(const std::string& tag);

}  // namespace moa::test
