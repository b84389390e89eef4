#include "moa/core/array.hpp"

#include <bit>
#include <numbers>

namespace moa {

int count_sensors(SensorMask mask) { return std::popcount(mask); }

SensorArray regular_polygon(int n, double r, double theta, const SensorMount& prototype) {
  SensorArray out(n, prototype);
  for (int i = 0; i < std::min(n, kMaxSensors); ++i) {
    const double a = theta + i * 2.0 * std::numbers::pi / n;
    out[i].position = r * Eigen::Vector2d(std::cos(a), std::sin(a));
    out[i].yaw = 0.0;
  }
  return out;
}

}  // namespace moa
