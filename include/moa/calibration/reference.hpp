// The reference side of a calibration and the checks of its result, free
// of files (io::calibrate_log reads the log and calls these).
#pragma once

#include <cstddef>
#include <span>
#include <string>
#include <vector>

#include "moa/core/se2.hpp"
#include "moa/core/sensor.hpp"

namespace moa {

/// Reference intervals (b_{k-1}, b_k], k = 1..m, and the robot twist
/// averaged over each (robot frame, m/s and rad/s).
struct ReferenceIntervals {
  std::vector<double> times;      ///< b_0 < b_1 < ... < b_m, s
  std::vector<Twist2> twists;     ///< m of them
  std::size_t repeated_rows = 0;  ///< rows not after the previous one: dropped
};

/// Reference rows (t_k, twist averaged over (t_{k-1}, t_k]) to intervals
/// of at least `min_interval` seconds: consecutive rows are merged, their
/// twists weighted by duration (the model is linear in the twist); t_0
/// only opens the first interval; rows not after the previous row give
/// empty intervals and are dropped (counted). A tail shorter than
/// `min_interval` is dropped. `t` and `twist` have the same size.
ReferenceIntervals reference_intervals(std::span<const double> t, std::span<const Twist2> twist,
                                       double min_interval);

/// Warnings about a calibrated mount against its nominal one: moved more
/// than 20 mm, a scale off by more than 20 %, mirroring that differs. One
/// line each, starting with the sensor's name.
std::vector<std::string> plausibility_warnings(const std::string& name, const SensorMount& nominal,
                                               const SensorMount& calibrated);

}  // namespace moa
