#include "moa/wheels.hpp"

#include <algorithm>

namespace moa {

bool WheelAverager::push(double t, const Twist2& twist) {
  if (!started_) {
    started_ = true;
    last_t_ = t;
    return true;
  }
  if (count_ == kCapacity) return false;
  ring_[(first_ + count_) % kCapacity] = Row{last_t_, t, twist};
  ++count_;
  last_t_ = t;
  return true;
}

std::optional<Twist2> WheelAverager::average(double a, double b) {
  while (count_ > 0 && at(0).end <= a) {
    first_ = (first_ + 1) % kCapacity;
    --count_;
  }
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double covered = 0.0;
  for (std::size_t k = 0; k < count_ && at(k).begin < b; ++k) {
    const double overlap = std::min(b, at(k).end) - std::max(a, at(k).begin);
    if (overlap <= 0.0) continue;
    sum += overlap * at(k).twist.vector();
    covered += overlap;
  }
  if (covered <= 0.0) return std::nullopt;
  return Twist2::from_vector(sum / covered);
}

}  // namespace moa
