// The coarse step of a latency search, shared by the gyro's calibration
// and the calibration against a camera: the peak of a correlation
// sampled on a grid of lags, refined by the parabola through it and its two
// neighbours (as Kalibr aligns two sensors' angular rates before fitting):
//   offset = (c_- - c_+) / (2 (c_- - 2 c_0 + c_+)),  |offset| <= 1/2 step.
#pragma once

#include <optional>
#include <span>

namespace moa {

struct LagPeak {
  double lag = 0.0;          ///< s, relative to the grid's centre
  double correlation = 0.0;  ///< at the grid's peak
};

/// `c` the correlation at lags (j - m) step, j = 0..2m (2m + 1 values). No
/// peak (nullopt) when fewer than 5 values, the largest is at either end of
/// the grid (the two series' alignment lies outside it), or is below
/// `min_correlation` (the series are not the same motion).
std::optional<LagPeak> correlation_peak(std::span<const double> c, double step,
                                        double min_correlation);

/// Pearson correlation of x and y (0 when either does not vary).
double pearson_correlation(std::span<const double> x, std::span<const double> y);

}  // namespace moa
