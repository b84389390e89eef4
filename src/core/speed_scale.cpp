#include "moa/core/speed_scale.hpp"

#include <algorithm>
#include <cmath>

namespace moa {

SpeedScale::SpeedScale(const real* speeds, const real* ratios, int n_speeds, int n_ratios) {
  n_ = std::clamp(std::min(n_speeds, n_ratios), 0, kMaxKnots);
  std::copy_n(speeds, n_, speeds_.begin());
  std::copy_n(ratios, n_, ratios_.begin());
  check(n_speeds, n_ratios);
}

void SpeedScale::check(int n_speeds, int n_ratios) {
  const auto fail = [&](Error e, int k) {
    error_ = e;
    error_knot_ = k;
  };
  if (n_speeds > kMaxKnots || n_ratios > kMaxKnots) {
    if (n_speeds != n_ratios) return fail(Error::kSizeMismatch, -1);
    return fail(Error::kTooManyKnots, -1);
  }
  if (n_speeds != n_ratios) return fail(Error::kSizeMismatch, -1);
  if (n_ < kMinKnots) return fail(Error::kTooFewKnots, -1);
  for (int k = 0; k < n_; ++k) {
    if (!std::isfinite(speed(k)) || speed(k) < 0) return fail(Error::kSpeedNotFinite, k);
  }
  for (int k = 1; k < n_; ++k) {
    if (!(speed(k) > speed(k - 1))) return fail(Error::kSpeedsNotIncreasing, k);
  }
  for (int k = 0; k < n_; ++k) {
    if (!(ratio_at(k) >= kMinRatio && ratio_at(k) <= kMaxRatio)) {
      return fail(Error::kRatioOutOfRange, k);
    }
  }
  // f'(s) = ratio(s) + m s at both ends of every segment (see the header).
  for (int k = 0; k + 1 < n_; ++k) {
    const real m = (ratio_at(k + 1) - ratio_at(k)) / (speed(k + 1) - speed(k));
    if (!(ratio_at(k) + m * speed(k) > 0) || !(ratio_at(k + 1) + m * speed(k + 1) > 0)) {
      return fail(Error::kNotMonotone, k + 1);
    }
  }
}

real SpeedScale::ratio(real s) const {
  if (!active()) return 1;
  if (!(s > speed(0))) return ratio_at(0);
  if (s >= speed(n_ - 1)) return ratio_at(n_ - 1);
  int k = 0;
  while (s >= speed(k + 1)) ++k;
  const real u = (s - speed(k)) / (speed(k + 1) - speed(k));
  return ratio_at(k) + u * (ratio_at(k + 1) - ratio_at(k));
}

real SpeedScale::true_speed(real c) const {
  if (!active()) return c;
  if (!(c > 0) || !std::isfinite(c)) return 0;
  // Below the first knot and above the last, f(s) = r s.
  if (c <= speed(0) * ratio_at(0)) return c / ratio_at(0);
  const int last = n_ - 1;
  if (c >= speed(last) * ratio_at(last)) return c / ratio_at(last);
  int k = 0;
  while (c >= speed(k + 1) * ratio_at(k + 1)) ++k;
  // On [s_k, s_k+1]: ratio(s) = b' + m s with b' = r_k - m s_k, so
  // f(s) = m s^2 + b' s = c. The root in the segment, written without the
  // cancellation of (-b' + sqrt(b'^2 + 4 m c)) / (2 m):
  //   s = 2 c / (b' + sqrt(b'^2 + 4 m c)),
  // where b'^2 + 4 m c = f'(s)^2 and b' + sqrt(.) = 2 ratio(s) > 0.
  const real m = (ratio_at(k + 1) - ratio_at(k)) / (speed(k + 1) - speed(k));
  const real b = ratio_at(k) - m * speed(k);
  const real disc = std::max<real>(b * b + 4 * m * c, 0);
  const real s = 2 * c / (b + std::sqrt(disc));
  return std::clamp(s, speed(k), speed(k + 1));
}

real SpeedScale::correction(real c) const {
  if (!active()) return 1;
  return 1 / ratio(true_speed(c));
}

const char* describe(SpeedScale::Error error) {
  switch (error) {
    case SpeedScale::Error::kTooFewKnots:
      return "needs at least 2 knots";
    case SpeedScale::Error::kTooManyKnots:
      return "has more than 8 knots";
    case SpeedScale::Error::kSizeMismatch:
      return "speeds and ratios differ in length";
    case SpeedScale::Error::kSpeedNotFinite:
      return "a speed is not a finite number >= 0";
    case SpeedScale::Error::kSpeedsNotIncreasing:
      return "speeds must be strictly increasing";
    case SpeedScale::Error::kRatioOutOfRange:
      return "a ratio is outside [0.5, 1.5]";
    case SpeedScale::Error::kNotMonotone:
      return "speed * ratio(speed) must increase with speed (the counts could not be inverted)";
  }
  return "invalid";
}

}  // namespace moa
