#include "moa/array.hpp"

#include <bit>
#include <numbers>

namespace moa {

int count_sensors(SensorMask mask) { return std::popcount(mask); }

SensorArray regular_polygon(int n, double r, double theta, const SensorMount& prototype) {
  std::vector<SensorMount> mounts;
  mounts.reserve(static_cast<std::size_t>(n > 0 ? n : 0));
  for (int i = 0; i < n; ++i) {
    const double a = theta + i * 2.0 * std::numbers::pi / n;
    SensorMount m = prototype;
    m.position = r * Eigen::Vector2d(std::cos(a), std::sin(a));
    m.yaw = 0.0;
    mounts.push_back(m);
  }
  return SensorArray(std::move(mounts));
}

}  // namespace moa
