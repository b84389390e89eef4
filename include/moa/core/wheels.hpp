// Wheel odometry twists (wheels.csv) resampled onto the estimator's epochs.
//
// Row k holds the twist averaged over (t_{k-1}, t_k]; the first row only
// opens the record. The twist over an epoch (a, b] is the overlap-weighted
// mean of the rows that cover it: sum_k x_k |I_k & (a,b]| / sum_k |I_k & (a,b]|,
// nullopt when no row covers any of it. Rows are kept in a fixed ring; rows
// that end before the last queried epoch are dropped.
#pragma once

#include <array>
#include <cstddef>
#include <optional>

#include "moa/core/ring.hpp"
#include "moa/core/se2.hpp"

namespace moa {

class WheelAverager {
 public:
  static constexpr std::size_t kCapacity = 256;

  /// Adds the next row (time-sorted). False when the ring is full: query
  /// (and so drop) older epochs first.
  bool push(double t, const Twist2& twist);
  /// True once a row at or after t has been pushed.
  bool covers(double t) const { return !rows_.empty() && last_t_ >= t; }
  /// Mean twist over (a, b]; drops rows that end at or before a.
  std::optional<Twist2> average(double a, double b);
  bool full() const { return rows_.full(); }

 private:
  struct Row {
    double begin, end;
    Twist2 twist;
  };
  FixedRing<Row, kCapacity> rows_;
  bool started_ = false;
  double last_t_ = 0.0;
};

}  // namespace moa
