#include "moa/core/consensus.hpp"

#include <Eigen/LU>
#include <algorithm>
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
    const SensorArray& array, ConsensusOptions options, const SelfCalibrationOptions& calibration) {
  // One sensor takes its rotation from the gyro (one_sensor()).
  if (array.size() == 1 && options.gyro_fed) {
    if (!valid_mount(array[0])) return GeometryError::kInvalidMount;
    return ConsensusEstimator(array, options, calibration);
  }
  // The same acceptance rules as the plain estimator over all sensors.
  const auto check = LsEstimator::create(array, all_sensors(array.size()), 0.01);
  if (const auto* error = std::get_if<GeometryError>(&check)) return *error;
  return ConsensusEstimator(array, options, calibration);
}

ConsensusEstimator::ConsensusEstimator(const SensorArray& array, ConsensusOptions options,
                                       const SelfCalibrationOptions& calibration)
    : n_(array.size()),
      options_(options),
      solver_(array),
      noise_(array, options.noise),
      prior_(options.limits),
      health_(array.size(), options.health, options.alpha),
      gyro_(options.gyro, array.rms_radius()) {
  for (int dof = 1; dof < 2 * kMaxSensors; ++dof) {
    threshold_[static_cast<std::size_t>(dof)] =
        static_cast<real>(chi2_quantile(1.0 - options_.alpha, dof));
  }
  wheel_threshold_ = static_cast<real>(chi2_quantile(1.0 - options_.alpha, 3));
  gyro_threshold_ = static_cast<real>(chi2_quantile(1.0 - options_.alpha, 1));
  if (calibration.enabled) calibration_.emplace(array, calibration, options_.noise);
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

void ConsensusEstimator::blame(const Candidate& best, const References& refs,
                               const SourceTests& tests, double t) {
  if (tests.gyro <= real(1)) {
    blame_ = Blame::kNone;  // they agree: the episode is over
    return;
  }
  if (!(tests.gyro > real(1))) return;  // not tested: the episode goes on
  if (blame_ == Blame::kNone) {
    // The onset: the wheels against the array where there are wheels (the
    // prior's rotation was the gyro's: no judge of the gyro), else the prior
    // (fresh).
    bool array_wrong = tests.wheels > real(1);
    for (int k = 0; k < refs.size && refs.wheels < 0; ++k) {
      const Reference& ref = refs.r[static_cast<std::size_t>(k)];
      const real d = best.fit.twist.omega - ref.x(2);
      array_wrong = array_wrong ||
                    d * d / (best.fit.covariance(2, 2) + ref.covariance(2, 2)) > gyro_threshold_;
    }
    blame_ = array_wrong ? Blame::kArray : Blame::kGyro;
    blame_since_ = t;
  } else if (blame_ == Blame::kArray &&
             t - blame_since_ > static_cast<double>(options_.max_bridge)) {
    blame_ = Blame::kGyro;  // wrong for longer than a lost floor lasts
  }
}

void ConsensusEstimator::drift_test(real z, real dt, const SourceTests& tests) {
  if (gyro_drift_h_ == 0) {
    // Two statistics, an epoch every dt s (cusum.hpp).
    gyro_drift_h_ = cusum_threshold(kDriftShift, 2 * kDriftFalseAlarmTime / dt);
  }
  const real clip = std::sqrt(gyro_threshold_);
  if (!std::isfinite(z)) return;
  const bool alarm = gyro_drift_.feed(std::clamp(z, -clip, clip), kDriftShift, gyro_drift_h_);
  const real cap = 2 * gyro_drift_h_;
  gyro_drift_.up = std::min(gyro_drift_.up, cap);
  gyro_drift_.down = std::min(gyro_drift_.down, cap);
  // The wheels, where there are, may still blame the array.
  if (alarm && !(tests.wheels > real(1))) gyro_drifting_ = true;
  if (gyro_drift_.up == 0 && gyro_drift_.down == 0) gyro_drifting_ = false;
}

bool ConsensusEstimator::common_mode(const Candidate& best, const References& refs,
                                     const SourceTests& tests, double t) const {
  if (!options_.common_mode || !options_.motion_prior) return false;
  if (!last_mice_t_ || t - *last_mice_t_ > static_cast<double>(options_.max_bridge)) return false;
  // The gyro's disagreement blamed on the array (of any subset: consider()
  // judged a minority against the translation references only).
  if (blame_ == Blame::kArray && tests.gyro > real(1)) return true;
  // A minority was judged against each translation reference already.
  if (2 * count_sensors(best.mask) <= n_) return false;
  // Every translation reference there is rejects the twist (a NaN ratio is
  // a reference not there).
  return refs.size > 0 && !(tests.wheels <= 1.0) && !(tests.prior <= 1.0);
}

void ConsensusEstimator::take_gyro_rotation(const GyroRate& rate, real omega,
                                            RobustEstimate& out) const {
  // The translation stays the array's (or the bridge's); the rotation is the
  // gyro's, independent of it.
  out.estimate.twist.omega = omega;
  out.estimate.covariance.row(2).setZero();
  out.estimate.covariance.col(2).setZero();
  out.estimate.covariance(2, 2) = rate.variance;
  out.tests.gyro_fused = true;
}

void ConsensusEstimator::teach_gyro(real g, const ArraySample& sample, const RobustEstimate& out,
                                    bool still) {
  // At rest (the wheels' encoders read nothing and the array agrees with
  // them) the robot's rotation is zero exactly: the gyro's window then
  // measures its bias alone, to its own noise d^2 T, not to the array's.
  constexpr SensorMask kStill = ~SensorMask{0};
  const SensorMask used = still ? kStill : out.estimate.used;
  for (int i = 0; i < n_ && !still; ++i) {
    // Low SQUAL or an overflow: counts that may be lost (near the rated speed
    // the variance is grown, the counts are still whole).
    if (contains(used, i) &&
        (out.noise_flags[static_cast<std::size_t>(i)] & (kNoiseLowSqual | kNoiseOverflow)) != 0) {
      (void)gyro_.close(gyro_threshold_);  // not a clean window
      gyro_mask_ = 0;
      return;
    }
  }
  if (used != gyro_mask_) {
    (void)gyro_.close(gyro_threshold_);
    gyro_mask_ = used;
    Mat3 q = Mat3::Zero();
    for (int i = 0; i < n_ && !still; ++i) {
      if (contains(used, i)) q += noise_.quantisation_information(i);
    }
    gyro_q_ = q.determinant() > 0 ? q.inverse()(2, 2) : real(0);
  }
  if (still) {
    (void)gyro_.teach(g, sample.dt, Vec3::Zero(), real(0), real(0), gyro_threshold_);
    return;
  }
  // The epoch's rotation variance less its quantisation (which the window
  // counts once): the sensors' noise and the resolution's variation.
  const real n =
      std::max(real(0), out.estimate.covariance(2, 2) - gyro_q_ / (sample.dt * sample.dt));
  (void)gyro_.teach(g, sample.dt, out.estimate.twist.vector(), gyro_q_, n, gyro_threshold_);
}

RobustEstimate ConsensusEstimator::one_sensor(int i, SensorMask candidates,
                                              const ArraySample& sample, const References& refs,
                                              const std::optional<Twist2>& wheels,
                                              const std::optional<real>& gyro,
                                              const std::optional<GyroRate>& rate,
                                              RobustEstimate out) {
  const auto s_i = static_cast<std::size_t>(i);
  const bool lifted = (sample.flags[s_i] & kFlagLift) != 0;
  const real dt = static_cast<real>(sample.dt);
  bool accepted = false;
  if (!lifted && rate) {
    // v = u - omega (z x r): (z x r) is the column of A_0 for omega.
    const Vec2 zr = solver_.jacobian(i).col(2);
    const Mat2 s = measurements_.info[s_i].inverse();
    Vec3 x;
    x << measurements_.u[s_i] - zr * rate->omega, rate->omega;
    Mat3 c;
    c.topLeftCorner<2, 2>() = s + zr * zr.transpose() * rate->variance;
    c.topRightCorner<2, 1>() = -zr * rate->variance;
    c.bottomLeftCorner<1, 2>() = -zr.transpose() * rate->variance;
    c(2, 2) = rate->variance;
    // The translation against each reference, 2 dof.
    bool any_passes = false;
    for (int k = 0; k < refs.size; ++k) {
      const Reference& ref = refs.r[static_cast<std::size_t>(k)];
      const Vec2 d = x.head<2>() - ref.x.head<2>();
      const Mat2 sum = c.topLeftCorner<2, 2>() + ref.covariance.topLeftCorner<2, 2>();
      const real ratio = d.dot(sum.inverse() * d) / threshold_[2];
      (k == refs.wheels ? out.tests.wheels : out.tests.prior) = ratio;
      any_passes = any_passes || ratio <= real(1);
    }
    const bool bridge = options_.common_mode && options_.motion_prior && refs.size > 0 &&
                        !any_passes && last_mice_t_ &&
                        sample.t - *last_mice_t_ <= static_cast<double>(options_.max_bridge);
    if (!bridge) {
      accepted = true;
      last_mice_t_ = sample.t;
      out.source = Source::kMice;
      out.estimate.twist = Twist2::from_vector(x);
      out.estimate.covariance = c;
      out.estimate.used = SensorMask{1} << i;
    }
  }
  if (accepted) {
    const real omega = gyro_.drive(*rate, dt);
    const bool still = wheels && wheels->vector().isZero(real(0)) && out.tests.wheels <= real(1);
    if (still) {
      teach_gyro(*gyro, sample, out, true);
    } else {
      (void)gyro_.close(gyro_threshold_);  // no rotation measured but the gyro's
      gyro_mask_ = 0;
    }
    take_gyro_rotation(*rate, omega, out);
    fallback_.good(out.estimate.twist, out.estimate.covariance, sample.t);
    prior_.trust(out.estimate.twist, out.estimate.covariance, sample.t);
    if (n_ > 1) {
      // The others left out are still tested against this twist (and may
      // come back).
      health_.observe(solver_, sample, measurements_, out.estimate.used, candidates,
                      out.noise_flags, &out.estimate);
    }
    test_sensors(out.estimate.twist, out.tests);
    return out;
  }
  out.excluded[s_i] =
      lifted ? Exclusion::kLift : (rate ? Exclusion::kCommonMode : Exclusion::kFallback);
  fallback_.apply(out, wheels, options_.wheels, options_.hold, sample.t);
  if (gyro) {
    (void)gyro_.close(gyro_threshold_);
    gyro_mask_ = 0;
  }
  if (rate) {
    take_gyro_rotation(*rate, gyro_.drive(*rate, dt), out);
  } else if (gyro) {
    out.estimate.twist.omega += gyro_.hold(out.estimate.covariance(2, 2), dt);
  }
  if (out.source == Source::kWheels) {
    prior_.trust(out.estimate.twist, out.estimate.covariance, sample.t);
  }
  return out;
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
  repeats_.count(sample);
  if (!calibration_) return estimate_counts(sample, 0, wheels, gyro);
  // The counts as the sensors would read with their estimated calibration;
  // a runaway or a correction held out as drift is left out of the search.
  corrected_ = sample;
  calibration_->correct(corrected_);
  SensorMask held = 0;
  for (int i = 0; i < n_; ++i) {
    if (calibration_->runaway(i) || calibration_->held_as_drift(i)) held |= SensorMask{1} << i;
  }
  RobustEstimate out = estimate_counts(corrected_, held, wheels, gyro);
  calibration_->observe(sample, out, wheels, repeats_);
  return out;
}

RobustEstimate ConsensusEstimator::estimate_counts(const ArraySample& sample, SensorMask held,
                                                   const std::optional<Twist2>& wheels,
                                                   const std::optional<real>& gyro) {
  RobustEstimate out;
  std::optional<GyroRate> rate;
  if (gyro) {
    gyro_.predict(sample.dt, *gyro);
    rate = gyro_.rate(*gyro, sample.dt);
    out.tests.gyro_saturated = !rate;
  }
  noise_.measure(sample, fallback_.last_twist(), measurements_, out.noise_flags);
  // The subsets below (and the health monitor's leave-one-out fits) sum
  // these terms instead of recomputing them.
  solver_.prepare(measurements_);

  SensorMask candidates = 0;
  for (int i = 0; i < n_; ++i) {
    if (contains(held, i)) {
      out.excluded[static_cast<std::size_t>(i)] =
          calibration_->runaway(i) ? Exclusion::kCalibration : Exclusion::kDrift;
    } else if (sample.flags[static_cast<std::size_t>(i)] & kFlagLift) {
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
  if (n_ == 1) return one_sensor(0, candidates, sample, refs, wheels, gyro, rate, out);
  const SensorMask screened = health_.screen(sample, candidates, repeats_, out.excluded);
  // The health monitor left one sensor: with the gyro it is an array of one.
  if (options_.gyro_fed && rate && count_sensors(screened) == 1) {
    int i = 0;
    while (!contains(screened, i)) ++i;
    return one_sensor(i, candidates, sample, refs, wheels, gyro, rate, out);
  }
  std::optional<Candidate> best = search(screened, refs);
  if (!best && options_.motion_prior && refs.size > 0) {
    // Step 2b: no subset passes, but the fit of all the candidates is a
    // twist every reference admits, with its own covariance alone (the
    // fit's, grown, would admit anything): a model error (latencies,
    // mounts) rather than a fault, and a better twist than a hold's. Its
    // covariance is grown by chi2 / dof, the unit variance's estimate.
    auto fit = solver_.fit(screened, measurements_);
    bool admitted = fit && fit->dof > 0;
    if (admitted) {
      // A model error is small beside the motion: the residuals pass the
      // gate with each point's covariance grown by (eps |p_i|)^2, eps =
      // kModelError of its predicted speed (a lost or frozen reading is
      // all of it).
      constexpr real kModelError = 0.1;
      real chi2 = 0;
      for (int i = 0; i < n_; ++i) {
        if (!contains(screened, i)) continue;
        const auto u = static_cast<std::size_t>(i);
        const Vec2 p = solver_.jacobian(i) * fit->twist.vector();
        const Vec2 r = measurements_.u[u] - p;
        const Mat2 c = measurements_.info[u].inverse() +
                       Mat2::Identity() * (kModelError * kModelError * p.squaredNorm());
        chi2 += r.dot(c.inverse() * r);
      }
      admitted = chi2 <= threshold_[static_cast<std::size_t>(fit->dof)];
    }
    for (int k = 0; admitted && k < refs.size; ++k) {
      const Reference& ref = refs.r[static_cast<std::size_t>(k)];
      const Vec3 d = fit->twist.vector() - ref.x;
      admitted = d.dot(ref.covariance.inverse() * d) <= wheel_threshold_;
    }
    if (admitted) {
      fit->covariance *= std::max(real(1), fit->chi2 / static_cast<real>(fit->dof));
      best = Candidate{*fit, screened, fit->chi2};
    }
  }
  if (best) test_references(*best, refs, out.tests);
  if (best && rate) {
    Vec3 x = best->fit.twist.vector();
    Mat3 c = best->fit.covariance;
    gyro_.decouple(x, c);
    const real d = x(2) - rate->omega;
    const real v = c(2, 2) + rate->variance;
    out.tests.gyro = d * d / v / gyro_threshold_;
    blame(*best, refs, out.tests, sample.t);
    // Not while the array is blamed (its readings are the fault).
    if (blame_ != Blame::kArray) {
      drift_test(d / std::sqrt(v), static_cast<real>(sample.dt), out.tests);
    }
  } else if (best) {
    blame(*best, refs, out.tests, sample.t);
  }
  const bool gyro_blamed = rate && (blame_ == Blame::kGyro || gyro_drifting_);
  out.tests.gyro_rejected = gyro_blamed;
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
    const bool still = wheels && wheels->vector().isZero(real(0)) && out.tests.wheels <= real(1);
    if (rate && !gyro_blamed) {
      // The gyro drives the heading (gyro.hpp); the array's own rotation
      // teaches it.
      const real omega = gyro_.drive(*rate, static_cast<real>(sample.dt));
      teach_gyro(*gyro, sample, out, still);
      take_gyro_rotation(*rate, omega, out);
    } else if (gyro) {
      // Saturated, or the one blamed: the rotation is the array's (and a
      // blamed gyro's readings are no calibration window).
      if (gyro_blamed) {
        (void)gyro_.close(gyro_threshold_);
        gyro_mask_ = 0;
      }
      out.estimate.twist.omega +=
          gyro_.hold(out.estimate.covariance(2, 2), static_cast<real>(sample.dt));
    }
    fallback_.good(out.estimate.twist, out.estimate.covariance, sample.t);
    prior_.trust(out.estimate.twist, out.estimate.covariance, sample.t);
    health_.observe(solver_, sample, measurements_, best->mask, candidates, out.noise_flags);
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
  if (gyro) (void)gyro_.close(gyro_threshold_);
  if (rate && !gyro_blamed) {
    take_gyro_rotation(*rate, gyro_.drive(*rate, static_cast<real>(sample.dt)), out);
  } else if (gyro) {
    out.estimate.twist.omega +=
        gyro_.hold(out.estimate.covariance(2, 2), static_cast<real>(sample.dt));
  }
  if (out.source == Source::kWheels) {
    prior_.trust(out.estimate.twist, out.estimate.covariance, sample.t);
  }
  // No set of sensors agreed: each is still tested, against the wheels' or
  // the hold's twist (two sensors that disagree: which one is wrong). Not
  // when the array as a whole was rejected (common-mode: every sensor's
  // reading is the fault, none is to be named).
  if (!common && n_ > 1) {
    health_.observe(solver_, sample, measurements_, 0, candidates, out.noise_flags, &out.estimate);
  }
  test_sensors(out.estimate.twist, out.tests);
  return out;
}

}  // namespace moa
