// Speed-dependent resolution of an optical sensor: it under-counts as the
// ground moves faster under it.
//
// ratio(s) is the ratio of counted to true displacement of the sensor point
// as a function of its true ground speed s (m/s): piecewise linear between
// knots (s_k, r_k), k = 0..n-1, s_k strictly increasing, and constant beyond
// the ends (r_0 below s_0, r_{n-1} above s_{n-1}). With d_true the sensor
// point's displacement over dt and s = |d_true| / dt, the sensor counts
//   d_counted = ratio(s) d_true,          so   |d_counted| / dt = f(s) = s ratio(s).
// The inversion (true_speed, correction) takes the counted speed c = |d_counted| / dt, finds
// the s with f(s) = c and returns the correction 1 / ratio(s) that turns the
// counted displacement (or the counts, a linear map of it) into the true one.
// f must be strictly increasing for s to be unique: on a segment with slope
// m = (r_{k+1} - r_k) / (s_{k+1} - s_k), f'(s) = ratio(s) + m s is linear in s,
// so it is positive on the segment iff it is at both ends; below s_0 and above
// s_{n-1}, f' = r_0 and r_{n-1}, positive by the ratios' bounds.
// Fixed-size (at most kMaxKnots knots), heap-free, no exceptions.
#pragma once

#include <array>
#include <optional>

#include "moa/core/real.hpp"

namespace moa {

class SpeedScale {
 public:
  static constexpr int kMaxKnots = 8;
  static constexpr int kMinKnots = 2;
  static constexpr real kMinRatio = 0.5;
  static constexpr real kMaxRatio = 1.5;

  /// Why a table is refused (the first problem found; error_knot() says where).
  enum class Error {
    kTooFewKnots,     ///< fewer than kMinKnots
    kTooManyKnots,    ///< more than kMaxKnots
    kSizeMismatch,    ///< speeds and ratios of different lengths
    kSpeedNotFinite,  ///< a speed is NaN or infinite, or < 0
    kSpeedsNotIncreasing,
    kRatioOutOfRange,  ///< a ratio outside [kMinRatio, kMaxRatio] (or NaN)
    kNotMonotone,      ///< s ratio(s) not strictly increasing
  };

  /// The identity: no table (ratio 1 at every speed).
  SpeedScale() = default;
  /// A table from its knots; `error()` says whether it is usable (a refused
  /// table keeps its knots for the message but `active()` is false).
  SpeedScale(const real* speeds, const real* ratios, int n_speeds, int n_ratios);

  /// Has a usable table (not the identity).
  bool active() const { return n_ > 0 && !error_; }
  std::optional<Error> error() const { return error_; }
  int size() const { return n_; }
  real speed(int k) const { return speeds_[static_cast<std::size_t>(k)]; }
  real ratio_at(int k) const { return ratios_[static_cast<std::size_t>(k)]; }
  /// The first knot where the error was found (-1 when none or not a knot's).
  int error_knot() const { return error_knot_; }

  /// ratio(s), s in m/s; 1 for the identity.
  real ratio(real speed) const;
  /// 1 / ratio(s) for the s with s ratio(s) = counted_speed (m/s, >= 0):
  /// the factor that turns counted displacement into true displacement.
  /// 1 for the identity; a non-finite or negative speed gives 1 too.
  real correction(real counted_speed) const;
  /// The s with s ratio(s) = counted_speed (m/s); counted_speed itself for
  /// the identity.
  real true_speed(real counted_speed) const;

 private:
  void check(int n_speeds, int n_ratios);  ///< sets error_ and error_knot_

  std::array<real, kMaxKnots> speeds_{};
  std::array<real, kMaxKnots> ratios_{};
  int n_ = 0;
  std::optional<Error> error_;
  int error_knot_ = -1;
};

/// A short English description of an error, for the layers above.
const char* describe(SpeedScale::Error error);

}  // namespace moa
