#include "moa/calibration/lag_search.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <iterator>

namespace moa {

std::optional<LagPeak> correlation_peak(std::span<const double> c, double step,
                                        double min_correlation) {
  if (c.size() < 5) return std::nullopt;
  const auto m = static_cast<std::ptrdiff_t>(c.size() / 2);
  const std::ptrdiff_t peak = std::distance(c.begin(), std::max_element(c.begin(), c.end()));
  const auto last = static_cast<std::ptrdiff_t>(c.size()) - 1;
  const double c0 = c[static_cast<std::size_t>(peak)];
  if (peak == 0 || peak == last || !(c0 >= min_correlation)) return std::nullopt;
  const double cm = c[static_cast<std::size_t>(peak - 1)];
  const double cp = c[static_cast<std::size_t>(peak + 1)];
  const double curvature = cm - 2.0 * c0 + cp;
  const double offset = curvature < 0.0 ? std::clamp(0.5 * (cm - cp) / curvature, -0.5, 0.5) : 0.0;
  return LagPeak{(static_cast<double>(peak - m) + offset) * step, c0};
}

double pearson_correlation(std::span<const double> x, std::span<const double> y) {
  double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
  const std::size_t k = std::min(x.size(), y.size());
  for (std::size_t i = 0; i < k; ++i) {
    sx += x[i];
    sy += y[i];
    sxx += x[i] * x[i];
    syy += y[i] * y[i];
    sxy += x[i] * y[i];
  }
  const auto n = static_cast<double>(k);
  const double vx = sxx - sx * sx / n, vy = syy - sy * sy / n;
  if (!(vx > 0.0) || !(vy > 0.0)) return 0.0;
  return (sxy - sx * sy / n) / std::sqrt(vx * vy);
}

}  // namespace moa
