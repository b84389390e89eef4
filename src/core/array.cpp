#include "moa/core/array.hpp"

#include <numbers>

namespace moa {

SensorArray regular_polygon(int n, real r, real theta, const SensorMount& prototype) {
  SensorArray out(n, prototype);
  for (int i = 0; i < std::min(n, kMaxSensors); ++i) {
    const real a =
        theta + static_cast<real>(i) * 2.0 * std::numbers::pi_v<real> / static_cast<real>(n);
    out[i].position = r * Vec2(std::cos(a), std::sin(a));
    out[i].yaw = 0.0;
  }
  return out;
}

}  // namespace moa
