#include "moa/core/consensus.hpp"

#include <Eigen/LU>
#include <cmath>

#include "moa/core/chi2.hpp"

namespace moa {

OptionCheck ConsensusOptions::validate() const {
  return OptionsCheck()
      .open("alpha", alpha, 0.0, 0.5)
      .positive("max_bridge", max_bridge)
      .nested("noise", noise.validate())
      .nested("wheels", wheels.validate())
      .nested("hold", hold.validate())
      .nested("limits", limits.validate())
      .nested("health", health.validate())
      .nested("gyro", gyro.validate())
      .result();
}

std::variant<ConsensusEstimator, GeometryError> ConsensusEstimator::create(
    const SensorArray& array, ConsensusOptions options) {
  // The same acceptance rules as the plain estimator over all sensors.
  const auto check = LsEstimator::create(array, all_sensors(array.size()), 0.01);
  if (const auto* error = std::get_if<GeometryError>(&check)) return *error;
  return ConsensusEstimator(array, options);
}

ConsensusEstimator::ConsensusEstimator(const SensorArray& array, ConsensusOptions options)
    : n_(array.size()),
      options_(options),
      solver_(array),
      noise_(array, options.noise),
      prior_(options.limits),
      health_(array.size(), options.health, options.alpha),
      gyro_(options.gyro) {
  for (int dof = 1; dof < 2 * kMaxSensors; ++dof) {
    threshold_[static_cast<std::size_t>(dof)] =
        static_cast<real>(chi2_quantile(1.0 - options_.alpha, dof));
  }
  wheel_threshold_ = static_cast<real>(chi2_quantile(1.0 - options_.alpha, 3));
  gyro_threshold_ = static_cast<real>(chi2_quantile(1.0 - options_.alpha, 1));
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

bool ConsensusEstimator::consider(SensorMask mask, References& refs, bool alone,
                                  std::optional<Candidate>& best) const {
  const auto fit = solver_.fit(mask, measurements_);
  if (!fit || fit->chi2 > threshold_[static_cast<std::size_t>(fit->dof)]) return false;
  const bool minority = 2 * count_sensors(mask) <= n_;
  const bool own_test = minority && options_.motion_prior;
  if (own_test && !refs.informed) {
    for (int k = 0; k < refs.size; ++k) {
      Reference& ref = refs.r[static_cast<std::size_t>(k)];
      ref.information = ref.covariance.inverse();
    }
    refs.informed = true;
  }
  real cost = fit->chi2;
  for (int k = 0; k < refs.size; ++k) {
    const Reference& ref = refs.r[static_cast<std::size_t>(k)];
    const Vec3 d = fit->twist.vector() - ref.x;
    // The joint term ranks the subsets of one size, and tests a minority
    // without the prior.
    real joint = 0.0;
    if (!alone || (minority && !options_.motion_prior)) {
      joint = d.dot((fit->covariance + ref.covariance).inverse() * d);
    }
    if (minority) {
      // The reference's covariance alone (the subset's own would let a pair
      // that under-reads alike through); before the prior: the joint one.
      const real own = own_test ? d.dot(ref.information * d) : joint;
      if (own > wheel_threshold_) return false;
    }
    cost += joint;
  }
  if (!best || cost < best->cost) best = Candidate{*fit, mask, cost};
  return true;
}

std::optional<ConsensusEstimator::Candidate> ConsensusEstimator::search(SensorMask candidates,
                                                                        References& refs) const {
  std::optional<Candidate> best;
  const int largest = count_sensors(candidates);
  if (n_ <= kMaxExhaustive) {
    // Largest subsets first; the first size with a consistent subset wins.
    const SensorMask end = SensorMask{1} << n_;
    for (int k = largest; k >= 2; --k) {
      for (SensorMask m = all_sensors(k); m < end; m = next_same_size(m)) {
        if ((m & ~candidates) == 0) consider(m, refs, k == largest, best);
      }
      if (best) return best;
    }
    return best;
  }
  // Greedy for large arrays: drop the sensor with the largest whitened
  // residual until the rest is consistent (the first that is wins: no
  // ranking).
  SensorMask mask = candidates;
  while (count_sensors(mask) >= 2) {
    if (consider(mask, refs, true, best)) return best;
    const auto fit = solver_.fit(mask, measurements_);
    if (!fit) return std::nullopt;
    int worst = -1;
    real worst_r2 = -1.0;
    for (int i = 0; i < n_; ++i) {
      if (!contains(mask, i)) continue;
      const auto s = static_cast<std::size_t>(i);
      const Vec2 r = measurements_.u[s] - solver_.jacobian(i) * fit->twist.vector();
      const real r2 = r.dot(measurements_.info[s] * r);
      if (r2 > worst_r2) worst_r2 = r2, worst = i;
    }
    mask &= ~(SensorMask{1} << worst);
  }
  return std::nullopt;
}

void ConsensusEstimator::test_references(const Candidate& best, const References& refs,
                                         SourceTests& tests) const {
  for (int k = 0; k < refs.size; ++k) {
    const Reference& ref = refs.r[static_cast<std::size_t>(k)];
    const Vec3 d = best.fit.twist.vector() - ref.x;
    const real ratio =
        d.dot((best.fit.covariance + ref.covariance).inverse() * d) / wheel_threshold_;
    (k == refs.wheels ? tests.wheels : tests.prior) = ratio;
  }
}

bool ConsensusEstimator::common_mode(const Candidate& best, const References& refs,
                                     const SourceTests& tests, double t) const {
  if (!options_.common_mode || !options_.motion_prior) return false;
  // A minority was judged against each reference already (consider()).
  if (2 * count_sensors(best.mask) <= n_) return false;
  if (!last_mice_t_ || t - *last_mice_t_ > static_cast<double>(options_.max_bridge)) return false;
  // The gyro rejects the rotation, or every translation reference there is
  // rejects the twist (a NaN ratio is a reference not there).
  if (tests.gyro > 1.0) return true;
  return refs.size > 0 && !(tests.wheels <= 1.0) && !(tests.prior <= 1.0);
}

void ConsensusEstimator::fuse_gyro(const GyroRate& rate, bool gated, RobustEstimate& out) const {
  Vec3 x = out.estimate.twist.vector();
  Mat3 p = out.estimate.covariance;
  const Mat<1, 1> y(rate.omega - x(2));
  const Mat<1, 3> h(real(0), real(0), real(1));
  const Mat<1, 1> r(rate.variance);
  if (gated) {
    out.tests.gyro_fused = gated_update<3, 1>(x, p, y, h, r, gyro_threshold_).fused;
  } else {
    joseph_update<3, 1>(x, p, y, h, r);
    out.tests.gyro_fused = true;
  }
  out.estimate.twist = Twist2::from_vector(x);
  out.estimate.covariance = p;
}

void ConsensusEstimator::test_sensors(const Twist2& x, SourceTests& tests) const {
  const real gate = threshold_[2];
  for (int i = 0; i < n_; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const Vec2 r = measurements_.u[k] - solver_.jacobian(i) * x.vector();
    tests.sensor[k] = r.dot(measurements_.info[k] * r) / gate;
  }
}

std::optional<RobustEstimate> ConsensusEstimator::estimate(const ArraySample& sample,
                                                           const std::optional<Twist2>& wheels,
                                                           const std::optional<real>& gyro) {
  if (!(std::isfinite(sample.dt) && sample.dt > 0.0) || sample.size != n_) return std::nullopt;
  RobustEstimate out;
  std::optional<GyroRate> rate;
  if (gyro) {
    gyro_.predict(sample.dt);
    rate = gyro_.rate(*gyro, sample.dt);
    out.tests.gyro_saturated = !rate;
  }
  noise_.measure(sample, fallback_.last_twist(), measurements_, out.noise_flags);
  // The subsets below (and the health monitor's leave-one-out fits) sum
  // these terms instead of recomputing them.
  solver_.prepare(measurements_);

  SensorMask candidates = 0;
  for (int i = 0; i < n_; ++i) {
    if (sample.flags[static_cast<std::size_t>(i)] & kFlagLift) {
      out.excluded[static_cast<std::size_t>(i)] = Exclusion::kLift;
    } else {
      candidates |= SensorMask{1} << i;
    }
  }
  References refs;
  const auto add = [&](const Twist2& x, const Mat3& covariance) {
    Reference& r = refs.r[static_cast<std::size_t>(refs.size++)];
    r.x = x.vector();
    r.covariance = covariance;
  };
  if (wheels) {
    refs.wheels = refs.size;
    add(*wheels, options_.wheels.covariance(*wheels));
  }
  if (options_.motion_prior && prior_.valid()) {
    add(prior_.twist(), prior_.covariance(sample.t, sample.dt));
  }
  const SensorMask screened =
      health_.screen(solver_, sample, fallback_.last_twist(), candidates, out.excluded);
  const auto best = search(screened, refs);
  if (best) test_references(*best, refs, out.tests);
  if (best && rate) {
    const real d = best->fit.twist.omega - rate->omega;
    out.tests.gyro = d * d / (best->fit.covariance(2, 2) + rate->variance) / gyro_threshold_;
  }
  const bool common = best && common_mode(*best, refs, out.tests, sample.t);
  if (best && !common) {
    last_mice_t_ = sample.t;
    out.source = Source::kMice;
    out.estimate.twist = best->fit.twist;
    out.estimate.covariance = best->fit.covariance;
    out.estimate.used = best->mask;
    for (int i = 0; i < n_; ++i) {
      if (contains(screened, i) && !contains(best->mask, i)) {
        out.excluded[static_cast<std::size_t>(i)] = Exclusion::kInconsistent;
      }
    }
    if (rate) {
      // The array's own rotation teaches the gyro, then the gyro's joins it.
      gyro_.calibrate(*gyro, sample.dt, out.estimate.twist.omega, out.estimate.covariance(2, 2),
                      gyro_threshold_);
      if (const auto taught = gyro_.rate(*gyro, sample.dt)) fuse_gyro(*taught, true, out);
    }
    fallback_.good(out.estimate.twist, out.estimate.covariance, sample.t);
    prior_.trust(out.estimate.twist, out.estimate.covariance, sample.t);
    health_.observe(solver_, sample, measurements_, out.estimate.twist, best->mask, candidates,
                    out.noise_flags);
    test_sensors(out.estimate.twist, out.tests);
    return out;
  }
  for (int i = 0; i < n_; ++i) {
    if (contains(screened, i)) {
      out.excluded[static_cast<std::size_t>(i)] =
          common ? Exclusion::kCommonMode : Exclusion::kFallback;
    }
  }
  fallback_.apply(out, wheels, options_.wheels, options_.hold, sample.t);
  if (rate) fuse_gyro(*rate, false, out);
  if (out.source == Source::kWheels) {
    prior_.trust(out.estimate.twist, out.estimate.covariance, sample.t);
  }
  test_sensors(out.estimate.twist, out.tests);
  return out;
}

}  // namespace moa
