// Page's CUSUM on normalised innovations, and its alarm level from a
// false-alarm rate.
//
// A one-sided statistic g <- max(0, g + z - k) of innovations z that are
// N(0, 1) while the model holds; a shift of the mean by mu > k sd makes g
// grow by about mu - k per sample, and an alarm is raised when g > h. The
// alarm level follows from the mean number of samples between false alarms
// under the model, ARL0, by Siegmund's approximation of the in-control run
// length,
//   ARL0 = (exp(2 k h') - 2 k h' - 1) / (2 k^2),  h' = h + 1.166,
// increasing in h', solved by bisection (k = 0.5, ARL0 = 1.44e6: h = 12.3).
#pragma once

#include <algorithm>
#include <cmath>

#include "moa/core/real.hpp"

namespace moa {

/// h (sd) for reference k (sd) and a mean run of `arl` samples between false
/// alarms.
inline real cusum_threshold(real k, real arl) {
  const auto run_length = [k](real hp) {
    return (std::exp(real(2) * k * hp) - real(2) * k * hp - real(1)) / (real(2) * k * k);
  };
  real lo = 0, hi = 1;
  while (run_length(hi) < arl && hi < real(1e6)) hi *= 2;
  for (int it = 0; it < 100; ++it) {
    const real mid = real(0.5) * (lo + hi);
    (run_length(mid) < arl ? lo : hi) = mid;
  }
  return std::max<real>(hi - real(1.166), 0);
}

/// The two one-sided statistics of one innovation stream: a shift either way.
struct TwoSidedCusum {
  real up = 0, down = 0;  ///< sd
  /// Feeds z (sd); true when either statistic exceeds h.
  bool feed(real z, real k, real h) {
    up = std::max<real>(0, up + z - k);
    down = std::max<real>(0, down - z - k);
    return up > h || down > h;
  }
  void reset() { up = down = 0; }
};

}  // namespace moa
