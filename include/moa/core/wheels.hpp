// Streams averaged over intervals (wheel odometry twists, gyro rates)
// resampled onto the estimator's epochs.
//
// Row k holds the value averaged over (t_{k-1}, t_k]; the first row only
// opens the record. The value over an epoch (a, b] is the overlap-weighted
// mean of the rows that cover it: sum_k x_k |I_k & (a,b]| / sum_k |I_k & (a,b]|,
// nullopt when no row covers any of it. Rows are kept in a fixed ring; rows
// that end before the last queried epoch are dropped.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <optional>

#include "moa/core/ring.hpp"
#include "moa/core/se2.hpp"

namespace moa {

/// The average above for a D-vector (double: the sums of a long interval).
template <int D>
class IntervalAverager {
 public:
  using Value = Eigen::Matrix<double, D, 1>;
  static constexpr std::size_t kCapacity = 256;

  /// Adds the next row (time-sorted). False when the ring is full: query
  /// (and so drop) older epochs first.
  bool push(double t, const Value& x) {
    if (!started_) {
      started_ = true;
      last_t_ = t;
      return true;
    }
    if (rows_.full()) return false;
    rows_.push_back(Row{last_t_, t, x});
    last_t_ = t;
    return true;
  }
  /// True once a row at or after t has been pushed.
  bool covers(double t) const { return !rows_.empty() && last_t_ >= t; }
  /// Mean over (a, b]; drops rows that end at or before a.
  std::optional<Value> average(double a, double b) {
    while (!rows_.empty() && rows_.front().end <= a) rows_.pop_front();
    Value sum = Value::Zero();
    double covered = 0.0;
    for (std::size_t k = 0; k < rows_.size() && rows_[k].begin < b; ++k) {
      const Row& row = rows_[k];
      const double overlap = std::min(b, row.end) - std::max(a, row.begin);
      if (overlap <= 0.0) continue;
      sum += overlap * row.x;
      covered += overlap;
    }
    if (covered <= 0.0) return std::nullopt;
    return Value(sum / covered);
  }
  bool full() const { return rows_.full(); }

 private:
  struct Row {
    double begin, end;
    Value x;
  };
  FixedRing<Row, kCapacity> rows_;
  bool started_ = false;
  double last_t_ = 0.0;
};

/// Wheel twists (robot frame, m/s and rad/s).
class WheelAverager {
 public:
  bool push(double t, const Twist2& twist) { return rows_.push(t, twist.vector().cast<double>()); }
  bool covers(double t) const { return rows_.covers(t); }
  std::optional<Twist2> average(double a, double b) {
    const auto x = rows_.average(a, b);
    if (!x) return std::nullopt;
    return Twist2::from_vector(x->cast<real>());
  }
  bool full() const { return rows_.full(); }

 private:
  IntervalAverager<3> rows_;
};

}  // namespace moa
