// Plausibility bounds of the streams beside the mice (whose counts are
// bounded by each sensor's rated speed: OdometryError::kImpossibleCounts):
// a wheel twist, a gyro rate, a camera fix or a pose beyond them is no
// measurement of a robot on mouse sensors but a corrupt value (1.7e308 in
// wheels.csv made odometry.csv's standard deviations inf and theta 1e306).
// The readers (formats/), the stream lines (sources/) and the pipeline
// (core/odometry.hpp, for every other front end) refuse it.
#pragma once

#include <cmath>

namespace moa {

/// m/s: a wheel twist's |vx| and |vy| (360 km/h).
inline constexpr double kMaxPlausibleSpeed = 100.0;
/// rad/s: a wheel twist's |omega|, a gyro's |gz| (about 160 turns a second;
/// MEMS gyros saturate below 70 rad/s).
inline constexpr double kMaxPlausibleRate = 1000.0;
/// m: |x| and |y| of a camera fix or a pose, and a fix's standard deviations.
inline constexpr double kMaxPlausiblePosition = 1e6;
/// rad: |theta| of a camera fix or a pose (unwrapped: a day at 100 rad/s).
inline constexpr double kMaxPlausibleHeading = 1e7;

/// |x| <= bound, and so finite (false for NaN).
inline bool within_plausible(double x, double bound) { return std::abs(x) <= bound; }

}  // namespace moa
