#include "moa/sim/clock.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace moa::sim {

std::int64_t frames_per_row(double frame_rate, double rate) {
  return std::max<std::int64_t>(1, std::llround(frame_rate / rate));
}

double StreamClock::stamp(double t) {
  if (timing_.latency == 0.0 && timing_.jitter == 0.0) return t;
  double s = t + timing_.latency;
  if (timing_.jitter > 0.0) s += timing_.jitter * (rng_.uniform() - 0.5);
  if (last_ && !(s > *last_)) s = std::nextafter(*last_, std::numeric_limits<double>::infinity());
  last_ = s;
  return s;
}

}  // namespace moa::sim
