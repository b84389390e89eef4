#include "moa/core/consensus.hpp"

#include <Eigen/LU>
#include <cmath>

#include "moa/core/chi2.hpp"

namespace moa {

std::variant<ConsensusEstimator, GeometryError> ConsensusEstimator::create(
    const SensorArray& array, ConsensusOptions options) {
  // The same acceptance rules as the plain estimator over all sensors.
  const auto check = LsEstimator::create(array, all_sensors(array.size()), 0.01);
  if (const auto* error = std::get_if<GeometryError>(&check)) return *error;
  return ConsensusEstimator(array, options);
}

ConsensusEstimator::ConsensusEstimator(const SensorArray& array, ConsensusOptions options)
    : n_(array.size()), options_(options), solver_(array), noise_(array, options.noise) {
  for (int dof = 1; dof < 2 * kMaxSensors; ++dof) {
    threshold_[static_cast<std::size_t>(dof)] = chi2_quantile(1.0 - options_.alpha, dof);
  }
  wheel_threshold_ = chi2_quantile(1.0 - options_.alpha, 3);
}

namespace {
// The next larger mask with the same number of bits set (Gosper's hack):
// the lowest run of ones moves up by one place and the rest of it drops to
// the bottom, so all k-subsets come in increasing numeric order.
SensorMask next_same_size(SensorMask m) {
  const SensorMask lowest = m & (~m + 1u);
  const SensorMask ripple = m + lowest;
  return (((ripple ^ m) >> 2) / lowest) | ripple;
}
}  // namespace

bool ConsensusEstimator::consider(SensorMask mask, const std::optional<Twist2>& wheels,
                                  const Eigen::Matrix3d& wheel_cov,
                                  std::optional<Candidate>& best) const {
  const auto fit = solver_.fit(mask, measurements_);
  if (!fit || fit->chi2 > threshold_[static_cast<std::size_t>(fit->dof)]) return false;
  double cost = fit->chi2;
  if (wheels) {
    const Eigen::Vector3d d = fit->twist.vector() - wheels->vector();
    const double distance = d.dot((fit->covariance + wheel_cov).inverse() * d);
    if (2 * count_sensors(mask) <= n_ && distance > wheel_threshold_) return false;
    cost += distance;
  }
  if (!best || cost < best->cost) best = Candidate{*fit, mask, cost};
  return true;
}

std::optional<ConsensusEstimator::Candidate> ConsensusEstimator::search(
    SensorMask candidates, const std::optional<Twist2>& wheels,
    const Eigen::Matrix3d& wheel_cov) const {
  std::optional<Candidate> best;
  if (n_ <= kMaxExhaustive) {
    // Largest subsets first; the first size with a consistent subset wins.
    const SensorMask end = SensorMask{1} << n_;
    for (int k = count_sensors(candidates); k >= 2; --k) {
      for (SensorMask m = all_sensors(k); m < end; m = next_same_size(m)) {
        if ((m & ~candidates) == 0) consider(m, wheels, wheel_cov, best);
      }
      if (best) return best;
    }
    return best;
  }
  // Greedy for large arrays: drop the sensor with the largest whitened
  // residual until the rest is consistent.
  SensorMask mask = candidates;
  while (count_sensors(mask) >= 2) {
    if (consider(mask, wheels, wheel_cov, best)) return best;
    const auto fit = solver_.fit(mask, measurements_);
    if (!fit) return std::nullopt;
    int worst = -1;
    double worst_r2 = -1.0;
    for (int i = 0; i < n_; ++i) {
      if (!contains(mask, i)) continue;
      const auto s = static_cast<std::size_t>(i);
      const Eigen::Vector2d r = measurements_.u[s] - solver_.jacobian(i) * fit->twist.vector();
      const double r2 = r.dot(measurements_.info[s] * r);
      if (r2 > worst_r2) worst_r2 = r2, worst = i;
    }
    mask &= ~(SensorMask{1} << worst);
  }
  return std::nullopt;
}

std::optional<RobustEstimate> ConsensusEstimator::estimate(const ArraySample& sample,
                                                           const std::optional<Twist2>& wheels) {
  if (!(std::isfinite(sample.dt) && sample.dt > 0.0) || sample.size != n_) return std::nullopt;
  RobustEstimate out;
  noise_.measure(sample, fallback_.last_twist(), measurements_, out.noise_flags);

  SensorMask candidates = 0;
  for (int i = 0; i < n_; ++i) {
    if (sample.flags[static_cast<std::size_t>(i)] & kFlagLift) {
      out.excluded[static_cast<std::size_t>(i)] = Exclusion::kLift;
    } else {
      candidates |= SensorMask{1} << i;
    }
  }
  const Eigen::Matrix3d wheel_cov =
      wheels ? options_.wheels.covariance(*wheels) : Eigen::Matrix3d::Zero();
  const auto best = search(candidates, wheels, wheel_cov);
  if (best) {
    out.source = Source::kMice;
    out.estimate.twist = best->fit.twist;
    out.estimate.covariance = best->fit.covariance;
    out.estimate.used = best->mask;
    for (int i = 0; i < n_; ++i) {
      if (contains(candidates, i) && !contains(best->mask, i)) {
        out.excluded[static_cast<std::size_t>(i)] = Exclusion::kInconsistent;
      }
    }
    fallback_.good(out.estimate.twist, out.estimate.covariance, sample.t);
    return out;
  }
  for (int i = 0; i < n_; ++i) {
    if (contains(candidates, i)) out.excluded[static_cast<std::size_t>(i)] = Exclusion::kFallback;
  }
  fallback_.apply(out, wheels, options_.wheels, options_.hold, sample.t);
  return out;
}

}  // namespace moa
