#include "moa/core/odometry.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "moa/core/plausible.hpp"

namespace moa {

const char* describe(OdometryError error) {
  switch (error) {
    case OdometryError::kRow:
      return "invalid mice row";
    case OdometryError::kNoInterval:
      return "an epoch has no positive, finite interval";
    case OdometryError::kWheelsFull:
      return "wheel rows fed too far ahead of the mice rows";
    case OdometryError::kFixesFull:
      return "camera fixes fed too far ahead of the mice rows";
    case OdometryError::kWheelsBackwards:
      return "wheel row time not finite or earlier than the previous one";
    case OdometryError::kImuFull:
      return "gyro rows fed too far ahead of the mice rows";
    case OdometryError::kImuBackwards:
      return "gyro row time not finite or earlier than the previous one";
    case OdometryError::kImpossibleCounts:
      return "counts imply a speed far beyond what the sensor can track (a corrupt value?)";
    case OdometryError::kImplausibleWheels:
      return "wheel twist beyond the plausible (|vx|, |vy| <= 100 m/s, |omega| <= 1000 rad/s; a "
             "corrupt value?)";
    case OdometryError::kImplausibleGyro:
      return "gyro rate beyond the plausible (|gz| <= 1000 rad/s; a corrupt value?)";
    case OdometryError::kImplausibleFix:
      return "camera fix beyond the plausible (|x|, |y| <= 1e6 m, |theta| <= 1e7 rad, standard "
             "deviations in (0, 1e6] m; a corrupt value?)";
  }
  return "?";
}

OptionCheck OdometryOptions::validate() const {
  InvalidOption names;  // "one of ls (0), sekimori (1), ..." from the name table
  names.append("one of ");
  for (const auto& entry : EnumNames<EstimatorKind>::kTable) {
    if (entry.value != EnumNames<EstimatorKind>::kTable[0].value) names.append(", ");
    names.append(entry.name);
    names.append(" (");
    names.append_integer(static_cast<long long>(entry.value));
    names.append(")");
  }
  OptionsCheck c;
  c.require(is_named(estimator), "estimator", names.message(), static_cast<double>(estimator))
      .require(sensors != 0, "sensors", "no sensor selected")
      .positive("rate", rate);
  // The synchroniser's own bounds, under the names of this struct's fields
  // (its period is 1 / rate, checked above).
  if (!c.failed()) c.nested("", synchroniser().validate());
  if (initial) {
    c.require(std::isfinite(initial->t.x()), "initial.x", "finite", initial->t.x())
        .require(std::isfinite(initial->t.y()), "initial.y", "finite", initial->t.y())
        .require(std::isfinite(initial->theta), "initial.theta", "finite", initial->theta);
  }
  if (camera_latency) c.closed("camera_latency", *camera_latency, -60.0, 60.0);
  c.closed("wheels_latency", wheels_latency, -60.0, 60.0)
      .positive("camera_sigma", camera_sigma)
      .positive("camera_heading_sigma", camera_heading_sigma)
      .nested("sekimori", sekimori.validate())
      .nested("consensus", consensus.validate())
      .nested("ekf", ekf.validate())
      .require(!ekf.estimate_scale || fuse_camera, "ekf.estimate_scale",
               "needs fuse_camera (the scales are estimated from camera fixes)")
      .nested("self_calibration", self_calibration.validate())
      .require(!self_calibration.enabled ||
                   (estimator != EstimatorKind::kLs && estimator != EstimatorKind::kSekimori &&
                    estimator != EstimatorKind::kOracle),
               "self_calibration",
               "needs the consensus estimator (ls, sekimori: one that runs away could not be "
               "left out; oracle: selects by fault labels)");
  return c.result();
}

namespace {
// The options' synchroniser with each sensor's latency (SensorMount::latency).
SynchroniserOptions synchroniser_options(const SensorArray& array, const OdometryOptions& o) {
  SynchroniserOptions s = o.synchroniser();
  for (int i = 0; i < std::min(array.size(), kMaxSensors); ++i) {
    s.latency[static_cast<std::size_t>(i)] = static_cast<double>(array[i].latency);
  }
  return s;
}
}  // namespace

Odometry::Odometry(const SensorArray& array, double t0, const OdometryOptions& options)
    : options_(options),
      n_(array.size()),
      m_(0),
      noise_(array, options.consensus.noise),
      sync_(array.size(), t0, synchroniser_options(array, options)),
      reckoner_(options.initial.value_or(Pose2{})),
      t0_(t0),
      period_(1.0 / options.rate) {
  if (n_ > kMaxSensors) {
    geometry_error_ = GeometryError::kTooManySensors;
    return;
  }
  if (synchroniser_options(array, options).validate()) {
    geometry_error_ = GeometryError::kLatencySpread;
    return;
  }
  for (int i = 0; i < n_; ++i) {
    const auto u = static_cast<std::size_t>(i);
    velocity_from_counts_[u] = array[i].robot_velocity_from_counts();
    impossible_speed_[u] = impossible_speed(array[i]);
    speed_scales_[u] = array[i].speed_scale;
    speed_scaled_ = speed_scaled_ || array[i].speed_scale.active();
  }
  // The selected sensors as an array of their own: every estimator sees
  // exactly the sensors it may use.
  std::array<SensorMount, kMaxSensors> mounts{};
  for (int i = 0; i < n_; ++i) {
    if (!contains(options_.sensors, i)) continue;
    selected_[static_cast<std::size_t>(m_)] = i;
    mounts[static_cast<std::size_t>(m_)] = array[i];
    ++m_;
  }
  sub_array_ =
      SensorArray(std::span<const SensorMount>(mounts.data(), static_cast<std::size_t>(m_)));
  noise_ = NoiseModel(sub_array_, options_.consensus.noise);
  const double period = 1.0 / options_.rate;
  const auto take = [&](auto built) {
    using T = std::decay_t<decltype(std::get<0>(built))>;
    if (const auto* e = std::get_if<GeometryError>(&built)) {
      geometry_error_ = *e;
    } else {
      estimator_.template emplace<T>(std::move(*std::get_if<T>(&built)));
    }
  };
  switch (options_.estimator) {
    case EstimatorKind::kLs:
      take(LsEstimator::create(sub_array_, all_sensors(m_), static_cast<real>(period)));
      break;
    case EstimatorKind::kSekimori:
      take(SekimoriEstimator::create(sub_array_, options_.sekimori));
      break;
    case EstimatorKind::kConsensus:
      take(ConsensusEstimator::create(sub_array_, options_.consensus, options_.self_calibration));
      break;
    case EstimatorKind::kWheels:
      break;
    case EstimatorKind::kOracle:
      // The same geometry checks as least squares over all selected sensors.
      // std::get_if, not std::get: no exception path (the core builds without
      // exceptions for microcontrollers).
      if (const auto built =
              LsEstimator::create(sub_array_, all_sensors(m_), static_cast<real>(period));
          const auto* e = std::get_if<GeometryError>(&built)) {
        geometry_error_ = *e;
      } else {
        estimator_.emplace<SubsetSolver>(sub_array_);
      }
      break;
  }
}

const Pose2& Odometry::pose() const { return ekf_ ? ekf_->pose() : reckoner_.pose(); }

Mat2 Odometry::fix_covariance(const CameraFix& fix) const {
  const Vec2 sd = fix.sigma ? *fix.sigma : Vec2::Constant(options_.camera_sigma);
  return sd.cwiseAbs2().asDiagonal();
}

std::optional<OdometryError> Odometry::push(const SensorRow& row, StepSink sink) {
  deferred_error_.reset();
  if (row.sensor >= 0 && row.sensor < n_ && std::isfinite(row.t) && row.counts.allFinite()) {
    // The row's interval as the synchroniser will take it, at least one epoch.
    const auto i = static_cast<std::size_t>(row.sensor);
    const double end = sync_.end_of_row(row);
    const double begin = std::max(sync_.last_time(row.sensor), end - options_.max_row_interval);
    const real dt = static_cast<real>(std::max(end - begin, period_));
    if (counts_impossible(velocity_from_counts_[i], row.counts, impossible_speed_[i], dt)) {
      return OdometryError::kImpossibleCounts;
    }
  }
  const auto error = sync_.push(row, [&](const ArraySample& s) { on_epoch(s, sink); });
  if (error) {
    row_error_ = *error;
    return OdometryError::kRow;
  }
  return deferred_error_;
}

std::optional<OdometryError> Odometry::push_wheels(double t, const Twist2& twist, StepSink sink) {
  if (!options_.use_wheels) return std::nullopt;
  if (!within_plausible(twist.v.x(), kMaxPlausibleSpeed) ||
      !within_plausible(twist.v.y(), kMaxPlausibleSpeed) ||
      !within_plausible(twist.omega, kMaxPlausibleRate)) {
    return OdometryError::kImplausibleWheels;
  }
  const double stamp = t;
  t -= options_.wheels_latency;  // the true end of its interval
  if (!std::isfinite(t) || (wheels_seen_ && t < last_wheel_t_)) {
    return OdometryError::kWheelsBackwards;
  }
  if (wheels_.full()) {
    // Rows older than the oldest waiting epoch are no longer needed.
    if (!ready_.empty())
      (void)wheels_.average(ready_.front().t - ready_.front().dt, ready_.front().t);
    if (wheels_.full()) return OdometryError::kWheelsFull;
  }
  wheels_.push(t, twist);
  wheels_seen_ = true;
  last_wheel_t_ = t;
  deferred_error_.reset();
  drain(false, sink);
  // Mice silent while the wheels report: the epochs no mice row can reach
  // any more are final, so the wheel rows they need do not pile up.
  sync_.advance(stamp, [&](const ArraySample& s) { on_epoch(s, sink); });
  return deferred_error_;
}

std::optional<OdometryError> Odometry::push_gyro(double t, double gz, StepSink sink, bool faulty) {
  if (!options_.use_imu) return std::nullopt;
  if (!within_plausible(gz, kMaxPlausibleRate)) return OdometryError::kImplausibleGyro;
  const double at = t - options_.consensus.gyro.latency;  // the true end of its interval
  if (!std::isfinite(at) || (gyro_seen_ && at < last_gyro_t_)) return OdometryError::kImuBackwards;
  if (gyro_.full()) {
    if (!ready_.empty())
      (void)gyro_.average(ready_.front().t - ready_.front().dt, ready_.front().t);
    if (gyro_.full()) return OdometryError::kImuFull;
  }
  // The oracle's faulty rows are NaN: an epoch they overlap averages to NaN
  // and the oracle leaves the gyro out there. No other estimator sees the truth.
  const bool hide = faulty && options_.estimator == EstimatorKind::kOracle;
  gyro_.push(at, IntervalAverager<1>::Value(hide ? std::numeric_limits<double>::quiet_NaN() : gz));
  gyro_seen_ = true;
  last_gyro_t_ = at;
  deferred_error_.reset();
  drain(false, sink);
  sync_.advance(t, [&](const ArraySample& s) { on_epoch(s, sink); });
  return deferred_error_;
}

std::optional<OdometryError> Odometry::push_fix(const CameraFix& fix) {
  if (!options_.fuse_camera) return std::nullopt;
  // A standard deviation is positive and at most kMaxPlausiblePosition.
  const auto sd_ok = [](double sd) { return sd > 0.0 && sd <= kMaxPlausiblePosition; };
  const bool sigma_ok = !fix.sigma || (sd_ok(fix.sigma->x()) && sd_ok(fix.sigma->y()));
  if (!within_plausible(fix.position.x(), kMaxPlausiblePosition) ||
      !within_plausible(fix.position.y(), kMaxPlausiblePosition) ||
      (fix.theta && !within_plausible(*fix.theta, kMaxPlausibleHeading)) || !sigma_ok) {
    return OdometryError::kImplausibleFix;
  }
  if (pending_fixes_.full()) return OdometryError::kFixesFull;
  pending_fixes_.push_back(fix);
  pending_fixes_.back().t -= options_.camera_latency.value_or(0.0);  // the capture time
  return std::nullopt;
}

void Odometry::finish(double t_end, StepSink sink) {
  sync_.finish(t_end, [&](const ArraySample& s) {
    // A zero-length tail carries no motion.
    if (std::isfinite(s.dt) && s.dt > 0.0) on_epoch(s, sink);
  });
  drain(true, sink);
}

bool Odometry::covered(double t) const {
  return (!(options_.use_wheels && wheels_seen_) || wheels_.covers(t)) &&
         (!(options_.use_imu && gyro_seen_) || gyro_.covers(t));
}

void Odometry::on_epoch(const ArraySample& sample, StepSink sink) {
  const bool wait = (options_.use_wheels && wheels_seen_) || (options_.use_imu && gyro_seen_);
  if (!wait && ready_.empty()) {
    process(sample, sink);
    return;
  }
  if (ready_.full()) {
    // The wheels lag too far: go on without their row for the oldest epoch.
    process(ready_.front(), sink);
    ready_.pop_front();
  }
  ready_.push_back(sample);
  drain(false, sink);
}

void Odometry::drain(bool all, StepSink sink) {
  while (!ready_.empty() && (all || covered(ready_.front().t))) {
    process(ready_.front(), sink);
    ready_.pop_front();
  }
}

void Odometry::apply_fixes(double t) {
  while (!pending_fixes_.empty()) {
    const CameraFix& f = pending_fixes_.front();
    // Not before the epochs reach its stamp (capture + latency).
    if (f.t + options_.camera_latency.value_or(0.0) > t) return;
    FixResult result;
    if (f.theta) {
      Mat3 r = Mat3::Zero();
      r.topLeftCorner<2, 2>() = fix_covariance(f);
      r(2, 2) = options_.camera_heading_sigma * options_.camera_heading_sigma;
      result = ekf_->update_pose(f.t, {f.position.x(), f.position.y(), *f.theta}, r);
    } else {
      result = ekf_->update_position(f.t, f.position, fix_covariance(f));
    }
    switch (result) {
      case FixResult::kApplied:
        ++fixes_.applied;
        break;
      case FixResult::kRejected:
        ++fixes_.rejected;
        break;
      case FixResult::kTooOld:
        ++fixes_.too_old;
        break;
      case FixResult::kFuture:
        return;  // keep it until the filter has reached its time
      case FixResult::kInvalid:
        ++fixes_.invalid;
        break;
    }
    pending_fixes_.pop_front();
  }
}

// The oracle's gyro: the config's model taken as true (the oracle runs on
// the true calibration), z = (g - c) / k with variance d^2 / (k^2 dt) (white
// noise of density d averaged over the epoch), fused into the twist as a
// measurement of omega: K = P e3 / (P_ww + r), x += K (z - omega),
// P -= K e3' P. Not where the simulator says the gyro was faulty.
void Odometry::fuse_oracle_gyro(real g, real dt, RobustEstimate& e) const {
  const GyroOptions& m = options_.consensus.gyro;
  if (!(dt > 0) || std::abs(g) >= GyroModel::kSaturation * m.max_rate) return;
  const real z = (g - m.bias) / m.scale;
  const real r = m.noise_density * m.noise_density / (m.scale * m.scale * dt);
  Mat3& p = e.estimate.covariance;
  const Vec3 k = p.col(2) / (p(2, 2) + r);
  Vec3 x = e.estimate.twist.vector();
  x += k * (z - x(2));
  const Mat3 joseph = Mat3::Identity() - k * Vec3::UnitZ().transpose();
  p = joseph * p * joseph.transpose() + r * k * k.transpose();
  e.estimate.twist = Twist2::from_vector(x);
}

bool Odometry::estimate(const ArraySample& sample, const std::optional<Twist2>& wheels,
                        const std::optional<real>& gyro, RobustEstimate& out) {
  // All sensors selected and no self-calibration (the usual case): the
  // epoch and the estimate are the estimator's own, with no copy into the
  // selection's indices and back.
  const bool all = m_ == n_;
  if (!all) {
    // The selected sensors' part of the epoch.
    compact_.t = sample.t;
    compact_.dt = sample.dt;
    compact_.size = m_;
    for (int k = 0; k < m_; ++k) {
      const auto i = static_cast<std::size_t>(selected_[static_cast<std::size_t>(k)]);
      const auto u = static_cast<std::size_t>(k);
      compact_.counts[u] = sample.counts[i];
      compact_.squal[u] = sample.squal[i];
      compact_.flags[u] = sample.flags[i];
      compact_.faults[u] = sample.faults[i];
    }
    selected_estimate_ = RobustEstimate{};
  }
  const ArraySample& in = all ? sample : compact_;
  RobustEstimate& e = all ? out : selected_estimate_;  // out comes default-constructed
  bool ok = true;
  if (auto* ls = std::get_if<LsEstimator>(&estimator_)) {
    const auto x = ls->estimate(in);
    ok = x.has_value();
    if (ok) e.estimate = *x;
  } else if (auto* s = std::get_if<SekimoriEstimator>(&estimator_)) {
    const auto x = s->estimate(in, wheels);
    ok = x.has_value();
    if (ok) e = *x;
  } else if (auto* c = std::get_if<ConsensusEstimator>(&estimator_)) {
    const auto x = c->estimate(in, wheels, gyro);
    ok = x.has_value();
    if (ok) e = *x;
  } else if (auto* solver = std::get_if<SubsetSolver>(&estimator_)) {
    // Oracle: least squares over the sensors the simulator says are sound,
    // weighted by the consensus's noise model.
    ok = std::isfinite(sample.dt) && sample.dt > 0.0;
    if (ok) {
      noise_.measure(in, fallback_.last_twist(), points_, e.noise_flags);
      SensorMask good = 0;
      for (int k = 0; k < m_; ++k) {
        if (in.faults[static_cast<std::size_t>(k)] == 0) {
          good |= SensorMask{1} << k;
        } else {
          e.excluded[static_cast<std::size_t>(k)] = Exclusion::kFaulty;
        }
      }
      if (const auto fit = solver->fit(good, points_)) {
        e.estimate.twist = fit->twist;
        e.estimate.covariance = fit->covariance;
        e.estimate.used = good;
        if (gyro) fuse_oracle_gyro(*gyro, static_cast<real>(sample.dt), e);
        fallback_.good(e.estimate.twist, e.estimate.covariance, sample.t);
      } else {
        for (int k = 0; k < m_; ++k) {
          if (contains(good, k)) e.excluded[static_cast<std::size_t>(k)] = Exclusion::kFallback;
        }
        fallback_.apply(e, wheels, options_.consensus.wheels, options_.consensus.hold, sample.t);
      }
    }
  } else {
    // Wheels alone: the mice are not used.
    ok = std::isfinite(sample.dt) && sample.dt > 0.0;
    fallback_.apply(e, wheels, options_.consensus.wheels, options_.consensus.hold, sample.t);
    if (wheels) fallback_.good(*wheels, e.estimate.covariance, sample.t);
    for (int k = 0; k < m_; ++k) e.excluded[static_cast<std::size_t>(k)] = Exclusion::kUnselected;
  }
  if (!ok) return false;
  const auto* consensus = std::get_if<ConsensusEstimator>(&estimator_);
  if (const SelfCalibration* c = consensus ? consensus->self_calibration() : nullptr) {
    for (int k = 0; k < m_; ++k) {
      const auto i = static_cast<std::size_t>(selected_[static_cast<std::size_t>(k)]);
      calibration_[i] = c->applied(k);
      calibration_filter_[i] = c->calibration(k);
      calibration_sd_[i] = c->sd(k);
      calibration_resets_[i] = c->resets(k);
    }
  }
  if (all) {
    // What the mapping below leaves past the array's sensors.
    for (auto i = static_cast<std::size_t>(n_); i < kMaxSensors; ++i) {
      out.excluded[i] = Exclusion::kNone;
      out.noise_flags[i] = 0;
    }
    return true;
  }
  // Back to the configured array's indices.
  out = RobustEstimate{};
  out.estimate.twist = e.estimate.twist;
  out.estimate.covariance = e.estimate.covariance;
  out.source = e.source;
  out.tests.wheels = e.tests.wheels;
  out.tests.prior = e.tests.prior;
  out.tests.gyro = e.tests.gyro;
  out.tests.gyro_fused = e.tests.gyro_fused;
  out.tests.gyro_saturated = e.tests.gyro_saturated;
  out.tests.gyro_rejected = e.tests.gyro_rejected;
  for (int i = 0; i < n_; ++i) out.excluded[static_cast<std::size_t>(i)] = Exclusion::kUnselected;
  for (int k = 0; k < m_; ++k) {
    const int i = selected_[static_cast<std::size_t>(k)];
    const auto u = static_cast<std::size_t>(i), v = static_cast<std::size_t>(k);
    if (contains(e.estimate.used, k)) out.estimate.used |= SensorMask{1} << i;
    out.excluded[u] = e.excluded[v];
    out.noise_flags[u] = e.noise_flags[v];
    out.tests.sensor[u] = e.tests.sensor[v];
  }
  return true;
}

const ArraySample& Odometry::undo_speed_scale(const ArraySample& sample) {
  if (!speed_scaled_) return sample;
  scaled_ = sample;
  for (int i = 0; i < std::min(sample.size, n_); ++i) {
    const auto u = static_cast<std::size_t>(i);
    scaled_.counts[u] =
        corrected_counts(speed_scales_[u], velocity_from_counts_[u], sample.counts[u], sample.dt);
  }
  return scaled_;
}

void Odometry::process(const ArraySample& raw, StepSink sink) {
  // The one place where a sensor's speed-dependent resolution is undone:
  // every estimator, the self-calibration and the sink see the corrected counts.
  const ArraySample& sample = undo_speed_scale(raw);
  const std::optional<Twist2> wheels = options_.use_wheels && wheels_seen_
                                           ? wheels_.average(sample.t - sample.dt, sample.t)
                                           : std::nullopt;
  std::optional<real> gyro;
  if (options_.use_imu && gyro_seen_) {
    const auto g = gyro_.average(sample.t - sample.dt, sample.t);
    if (g && std::isfinite((*g)(0))) gyro = static_cast<real>((*g)(0));
  }
  OdometryStep step;
  step.sample = &sample;
  if (options_.self_calibration.enabled) {
    step.calibration = &calibration_;
    step.calibration_filter = &calibration_filter_;
    step.calibration_sd = &calibration_sd_;
    step.calibration_resets = &calibration_resets_;
  }
  if (options_.use_imu && gyro_seen_) {
    if (const auto* consensus = std::get_if<ConsensusEstimator>(&estimator_)) {
      step.gyro = &consensus->gyro();
    }
  }
  if (!estimate(sample, wheels, gyro, step.estimate)) {
    deferred_error_ = OdometryError::kNoInterval;
    return;
  }
  if (!started_) {
    started_ = true;
    if (options_.fuse_camera) {
      // The filter starts at the given pose, or at the first fix's position.
      Mat3 p0 = Vec3(1e-8, 1e-8, 1e-8).asDiagonal();
      Pose2 initial = options_.initial.value_or(Pose2{});
      if (!options_.initial && !pending_fixes_.empty()) {
        initial.t = pending_fixes_.front().position;
        p0.topLeftCorner<2, 2>() = fix_covariance(pending_fixes_.front());
        p0(2, 2) = 1e-4;
        pending_fixes_.pop_front();  // it made the initial position
      }
      ekf_.emplace(t0_, initial, p0, options_.ekf);
    }
  }
  const Twist2& twist = step.estimate.estimate.twist;
  if (ekf_) {
    ekf_->predict(sample.t, twist, step.estimate.estimate.covariance, sample.dt);
    apply_fixes(sample.t);
    step.pose = ekf_->pose();
    step.fused = true;
    step.pose_covariance = ekf_->covariance();
    if (ekf_->estimates_scale()) {
      step.scaled = true;
      step.scale = ekf_->scale();
      step.scale_covariance = ekf_->scale_covariance();
    }
  } else {
    step.pose = reckoner_.step(twist, sample.dt);
  }
  ++steps_;
  sink(step);
}

}  // namespace moa
