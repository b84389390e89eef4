#include "moa/sim/gyro.hpp"

#include <algorithm>
#include <cmath>

namespace moa::sim {

double SimGyro::clamp(double r) const { return std::clamp(r, -spec_.max_rate, spec_.max_rate); }

void SimGyro::frame(double omega, double h) {
  const double mid = t_ + 0.5 * h;
  for (std::size_t f = 0; f < spec_.faults.size(); ++f) {
    const GyroFault& fault = spec_.faults[f];
    if (fault.kind == GyroFault::kBiasStep && !stepped_[f] && mid >= fault.start) {
      bias_ += fault.step;
      stepped_[f] = true;
      stepped_any_ = true;
    }
  }
  t_ += h;
  const double r = spec_.scale * omega + bias_;
  if (std::abs(r) >= spec_.max_rate) saturating_ = true;
  sum_ += clamp(r) * h;
  if (spec_.bias_walk > 0.0) bias_ += spec_.bias_walk * std::sqrt(h) * rng_.normal();
}

double SimGyro::take_row(double dt) {
  const double mean = sum_ / dt;
  sum_ = 0.0;
  // The noise is drawn in every row, stuck or not, so a fault changes no other row.
  const double noisy = mean + spec_.noise_density / std::sqrt(dt) * rng_.normal();
  const double row = clamp(noisy);
  row_saturated_ = saturating_ || std::abs(noisy) >= spec_.max_rate;
  saturating_ = false;
  row_faulty_ = row_saturated_ || stepped_any_;
  const double mid = t_ - 0.5 * dt;
  for (const GyroFault& fault : spec_.faults) {
    if (fault.kind == GyroFault::kStuck && mid >= fault.start && mid < fault.end) {
      row_faulty_ = true;
      return last_row_;
    }
  }
  last_row_ = row;
  return row;
}

}  // namespace moa::sim
