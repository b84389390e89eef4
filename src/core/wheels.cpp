#include "moa/core/wheels.hpp"

#include <algorithm>

namespace moa {

bool WheelAverager::push(double t, const Twist2& twist) {
  if (!started_) {
    started_ = true;
    last_t_ = t;
    return true;
  }
  if (rows_.full()) return false;
  rows_.push_back(Row{last_t_, t, twist});
  last_t_ = t;
  return true;
}

std::optional<Twist2> WheelAverager::average(double a, double b) {
  while (!rows_.empty() && rows_.front().end <= a) rows_.pop_front();
  Vec3 sum = Vec3::Zero();
  double covered = 0.0;
  for (std::size_t k = 0; k < rows_.size() && rows_[k].begin < b; ++k) {
    const Row& row = rows_[k];
    const double overlap = std::min(b, row.end) - std::max(a, row.begin);
    if (overlap <= 0.0) continue;
    sum += overlap * row.twist.vector();
    covered += overlap;
  }
  if (covered <= 0.0) return std::nullopt;
  return Twist2::from_vector(sum / covered);
}

}  // namespace moa
