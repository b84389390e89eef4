#include "moa/sim/gyro.hpp"

#include <algorithm>
#include <cmath>

namespace moa::sim {

double SimGyro::clamp(double r) const { return std::clamp(r, -spec_.max_rate, spec_.max_rate); }

void SimGyro::frame(double omega, double h) {
  sum_ += clamp(spec_.scale * omega + bias_) * h;
  if (spec_.bias_walk > 0.0) bias_ += spec_.bias_walk * std::sqrt(h) * rng_.normal();
}

double SimGyro::take_row(double dt) {
  const double mean = sum_ / dt;
  sum_ = 0.0;
  return clamp(mean + spec_.noise_density / std::sqrt(dt) * rng_.normal());
}

}  // namespace moa::sim
