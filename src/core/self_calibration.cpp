#include "moa/core/self_calibration.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>

#include "moa/core/chi2.hpp"
#include "moa/core/kalman.hpp"
#include "moa/core/se2.hpp"

namespace moa {

namespace {

/// The test that applies an estimate (header, "Applied"): |deviation| > z
/// sqrt(variance), z = Phi^-1(1 - apply_alpha / 2).
bool significant(real z, real deviation, real variance) {
  return std::abs(deviation) > z * std::sqrt(std::max<real>(variance, 0.0));
}

}  // namespace

OptionCheck SelfCalibrationOptions::validate() const {
  return OptionsCheck()
      .require(is_named(gauge), "gauge", "sensors (0) or wheels (1)", static_cast<double>(gauge))
      .positive("block", block)
      .non_negative("min_speed", min_speed)
      .non_negative("scale_walk", scale_walk)
      .non_negative("yaw_walk", yaw_walk)
      .positive("prior_scale_sd", prior_scale_sd)
      .positive("prior_yaw_sd", prior_yaw_sd)
      .non_negative("relative_noise", relative_noise)
      .open("apply_alpha", apply_alpha, 0.0, 1.0)
      .non_negative("mount_position_sigma", mount_position_sigma)
      .open("gross_alpha", gross_alpha, 0.0, 1.0)
      .open("predictor_alpha", predictor_alpha, 0.0, 1.0)
      .open("runaway_scale", runaway_scale, 0.0, 1.0)
      .positive("runaway_yaw", runaway_yaw)
      .open("runaway_alpha", runaway_alpha, 0.0, 0.5)
      .positive("reset_false_alarm_time", reset_false_alarm_time)
      .open("reset_rate", reset_rate, gross_alpha, 1.0)
      .positive("reset_scale_sd", reset_scale_sd)
      .positive("reset_yaw_sd", reset_yaw_sd)
      .positive("settle_time", settle_time)
      .open("hold_alpha", hold_alpha, 0.0, 1.0)
      .non_negative("apply_step", apply_step)
      .at_least("repeat_run", repeat_run, 2)
      .non_negative("gauge_walk", gauge_walk)
      .non_negative("wheel_noise", wheel_noise)
      .result();
}

SelfCalibration::SelfCalibration(const SensorArray& array, SelfCalibrationOptions options,
                                 const NoiseModelOptions& noise)
    : options_(options),
      noise_(noise),
      n_(std::min(array.size(), kMaxSensors)),
      array_(array),
      solver_(array) {
  const Vec3 prior(options_.prior_scale_sd, options_.prior_scale_sd, options_.prior_yaw_sd);
  for (int i = 0; i < n_; ++i) {
    const auto u = static_cast<std::size_t>(i);
    velocity_from_counts_[u] = array[i].robot_velocity_from_counts();
    metres_per_count_[u] =
        1.0 / (array[i].counts_per_metre() * std::min(array[i].scale.x(), array[i].scale.y()));
    state_[u].p = prior.cwiseAbs2().asDiagonal();
  }
  points_.size = n_;
  for (std::size_t d = 1; d < chi2_gate_.size(); ++d) {
    chi2_gate_[d] =
        static_cast<real>(chi2_quantile(1.0 - options_.predictor_alpha, static_cast<int>(d)));
  }
  block_gate_ = static_cast<real>(chi2_quantile(1.0 - options_.gross_alpha, 2));
  wheel_gate_ = static_cast<real>(chi2_quantile(1.0 - options_.gross_alpha, 3));
  // The rejections' CUSUM (header): log-likelihood ratios of a block
  // rejected and fused, rejection rate reset_rate against gross_alpha.
  const double a = options_.gross_alpha, b = options_.reset_rate;
  llr_rejected_ = static_cast<real>(std::log(b / a));
  llr_fused_ = static_cast<real>(std::log((1.0 - b) / (1.0 - a)));
  reset_h_ =
      static_cast<real>(std::log(std::max(1.0, options_.reset_false_alarm_time / options_.block)));
  // One-sided normal quantile from the chi-square of 1 dof: P(Z > z) = alpha
  // is P(Z^2 > z^2) = 2 alpha.
  runaway_z_ = static_cast<real>(std::sqrt(chi2_quantile(1.0 - 2.0 * options_.runaway_alpha, 1)));
  apply_z_ = static_cast<real>(std::sqrt(chi2_quantile(1.0 - options_.apply_alpha, 1)));
  hold_z_ = static_cast<real>(std::sqrt(chi2_quantile(1.0 - options_.hold_alpha, 1)));
  real r2 = 0.0;
  for (int i = 0; i < n_; ++i) {
    r2 += array[i].position.squaredNorm();
    // The mount position's bias, relative (header, "Applied"); a sensor
    // nearer the centre than 1 cm (its own footprint) counts as 1 cm out.
    mount_bias_[static_cast<std::size_t>(i)] =
        options_.mount_position_sigma / std::max<real>(array[i].position.norm(), 0.01);
  }
  radius_ = n_ > 0 ? std::sqrt(r2 / static_cast<real>(n_)) : 0.0;
  wheel_.p = Mat2::Identity() * (options_.prior_scale_sd * options_.prior_scale_sd);
}

Vec3 SelfCalibration::sd(int i) const {
  return state_[static_cast<std::size_t>(i)].p.diagonal().cwiseMax(0.0).cwiseSqrt();
}

bool SelfCalibration::held_as_drift(int i) const {
  const SensorState& s = state_[static_cast<std::size_t>(i)];
  return s.corrected && s.settling;
}

SensorMask SelfCalibration::runaways() const {
  SensorMask m = 0;
  for (int i = 0; i < n_; ++i) {
    if (state_[static_cast<std::size_t>(i)].runaway) m |= SensorMask{1} << i;
  }
  return m;
}

void SelfCalibration::correct(ArraySample& sample) const {
  for (int i = 0; i < std::min(n_, sample.size); ++i) {
    const auto u = static_cast<std::size_t>(i);
    sample.counts[u] = state_[u].correction * sample.counts[u];
  }
}

void SelfCalibration::renew(int i) {
  SensorState& s = state_[static_cast<std::size_t>(i)];
  const real change = std::max({std::abs(s.theta.scale_x - s.renewed.scale_x),
                                std::abs(s.theta.scale_y - s.renewed.scale_y),
                                std::abs(s.theta.yaw_offset - s.renewed.yaw_offset)});
  // Renewed too when the gauge's applied part changed: the others'
  // predictions take every correction to carry the same (Gc, Dc) (observe).
  const SelfCalibrationEstimate common = applied_gauge();
  const bool same_common = common.scale_x == s.renewed_common.scale_x &&
                           common.scale_y == s.renewed_common.scale_y &&
                           common.yaw_offset == s.renewed_common.yaw_offset;
  if (change < options_.apply_step && same_common) return;
  s.renewed = s.theta;
  s.renewed_common = common;
  // Applied where it differs from the configuration (header, "Applied"):
  // a component is applied when it is more than z sd of its error from the
  // configured value, the error's variance P's plus the mount position's
  // bias b^2 (b^2 / 4 on the isotropic part). The test judges the relative
  // calibration theta / (G, D); the gauge's common part (G, D) has its own
  // (applied_gauge; with kSensors it is (1, 0), exactly).
  const SelfCalibrationEstimate common_part = gauge();
  const real gs = common_part.scale_x, gy = common_part.yaw_offset;
  const SelfCalibrationEstimate rel{s.theta.scale_x / gs, s.theta.scale_y / gs,
                                    s.theta.yaw_offset - gy};
  const real b2 =
      mount_bias_[static_cast<std::size_t>(i)] * mount_bias_[static_cast<std::size_t>(i)];
  const real g = std::sqrt(rel.scale_x * rel.scale_y);
  // g - 1 ~ ((s_x - 1) + (s_y - 1)) / 2: variance (P_xx + P_yy + 2 P_xy) / 4.
  const real var_g = 0.25 * (s.p(0, 0) + s.p(1, 1) + 2.0 * s.p(0, 1)) / (gs * gs);
  const bool off = significant(apply_z_, rel.scale_x - 1.0, s.p(0, 0) / (gs * gs) + b2) ||
                   significant(apply_z_, rel.scale_y - 1.0, s.p(1, 1) / (gs * gs) + b2);
  const bool dimmed = significant(apply_z_, g - 1.0, var_g + 0.25 * b2);
  const bool turned = significant(apply_z_, rel.yaw_offset, s.p(2, 2) + b2);
  s.corrected = off || dimmed || turned;
  s.applied = {common.scale_x * (off ? rel.scale_x : (dimmed ? g : 1.0)),
               common.scale_y * (off ? rel.scale_y : (dimmed ? g : 1.0)),
               common.yaw_offset + (off || turned ? rel.yaw_offset : 0.0)};
  const SelfCalibrationEstimate& used = s.applied;
  // counts -> robot velocity (configured), into the configured sensor frame,
  // C^-1 = R(delta) diag(1/s), back to the robot frame and to counts.
  const Mat2& v = velocity_from_counts_[static_cast<std::size_t>(i)];
  const Mat2 r = rotation(array_[i].yaw);
  const Mat2 c_inv =
      rotation(used.yaw_offset) * Vec2(1.0 / used.scale_x, 1.0 / used.scale_y).asDiagonal();
  s.correction = v.inverse() * r * c_inv * r.transpose() * v;
}

void SelfCalibration::observe(const ArraySample& raw, const RobustEstimate& estimate,
                              const std::optional<Twist2>& wheels, const RepeatCounter& repeats) {
  if (estimate.source != Source::kMice || !(std::isfinite(raw.dt) && raw.dt > 0.0)) return;
  const real dt = raw.dt;
  // Corrected point velocities of every sensor, weighed by their
  // quantisation and a relative term (not the estimators' 2 %: that term
  // stands for calibration errors, which are what is estimated here).
  for (int k = 0; k < n_; ++k) {
    const auto u = static_cast<std::size_t>(k);
    points_.u[u] = velocity_from_counts_[u] * (state_[u].correction * raw.counts[u]) / dt;
    const real q = metres_per_count_[u] / dt;
    const real rel = options_.relative_noise * points_.u[u].norm();
    points_.info[u] = Mat2::Identity() / (q * q / 6.0 + rel * rel + 1e-12);
  }
  // Counts alike (not zero) for the last three epochs are what a frozen
  // register reads before the estimator can tell (the estimator's repeat
  // counter, by which health.hpp names an alarm frozen): such a sensor does
  // not predict the others
  // this epoch, nor (after repeat_run) teach its own block. A good sensor's
  // chance run costs one predictor for an epoch. (faults-stuck seed 201:
  // the stuck register predicting the others for its first 0.1 s, before
  // the alarm, taught m1 a 1.5 % change, held out for 1.5 s: 45.9 mm, now
  // 13.4; the plain consensus 13.7.)
  SensorMask repeating = 0;
  for (int k = 0; k < n_; ++k) {
    if (repeats.repeats(k) >= 2) repeating |= SensorMask{1} << k;
  }
  const SensorMask used = estimate.estimate.used;
  // The others' corrections carry the applied common part (Gc, Dc), theta
  // the gauge's (G, D): a prediction in theta's gauge is (Gc / G) R(D - Dc)
  // times theirs (robot frame). Without it every block of every sensor would
  // pull theta towards the applied common part, against fix_gauge(), and on
  // a path that leaves a direction of theta open that tug drives it off.
  Mat2 to_gauge = Mat2::Identity();
  if (options_.gauge == SelfCalibrationGauge::kWheels) {
    const SelfCalibrationEstimate g = gauge(), gc = applied_gauge();
    to_gauge = (gc.scale_x / g.scale_x) * rotation(g.yaw_offset - gc.yaw_offset);
  }
  for (int i = 0; i < n_; ++i) {
    const auto u = static_cast<std::size_t>(i);
    switch (estimate.excluded[u]) {
      case Exclusion::kNone:
      case Exclusion::kInconsistent:
      case Exclusion::kUnreliable:
      case Exclusion::kDrift:
      case Exclusion::kProbation:
      case Exclusion::kCalibration:
        break;
      default:
        continue;  // lift, frozen, zero, faulty, unselected, fallback
    }
    if (raw.flags[u] & (kFlagLift | kFlagOverflow)) continue;
    if (raw.squal[u] < noise_.min_squal) continue;
    if (raw.counts[u].isZero()) continue;
    // A run of repeat_run epochs of counts repeated exactly is what a frozen
    // register reads before the estimator's test can tell (health.hpp: in a
    // steady cruise it waits for the motion to change): learnt as a scale, the correction
    // it teaches would change the repeated counts and hide the fault. So a
    // block ends only on an epoch whose counts differ from the one before (it
    // grows while they repeat), and a block in which a run reaches
    // repeat_run is dropped; shorter runs are chance and kept (leaving out
    // epochs by their counts would break the block's telescoping sum).
    if (repeats.repeats(i) + 1 >= options_.repeat_run) {
      state_[u].clear_block();
      continue;
    }
    // Over its rating a sensor loses counts at random (the noise model's
    // gross error, not a calibration): its block is dropped, as the health
    // monitor's test is not fed there (health.hpp), so that neither the
    // update nor the rejections' CUSUM reads it.
    if (estimate.noise_flags[u] & kNoiseOverRating) {
      state_[u].clear_block();
      continue;
    }
    const SensorMask others = used & ~repeating & ~(SensorMask{1} << i);
    if (count_sensors(others) < 2) continue;
    const auto fit = solver_.fit(others, points_);
    if (!fit) continue;
    // The others must agree among themselves (chi-square of their fit under
    // this filter's noise: quantisation and relative_noise): a fault in one
    // of them that the estimator has not caught yet (a step of its scale)
    // would otherwise be learnt by every other sensor.
    if (fit->dof > 0 && fit->chi2 > chi2_gate_[static_cast<std::size_t>(fit->dof)]) continue;
    Vec2 p = solver_.jacobian(i) * fit->twist.vector();
    if (options_.gauge == SelfCalibrationGauge::kWheels) p = to_gauge * p;
    const Mat2 rt = rotation(array_[i].yaw).transpose();
    SensorState& s = state_[u];
    s.sum_pred += rt * p * dt;
    s.sum_meas += rt * velocity_from_counts_[u] * raw.counts[u];
    const Mat<2, 3>& a = solver_.jacobian(i);
    s.sum_var += 0.5 * (a * fit->covariance * a.transpose()).trace() * dt * dt;
    // Near its rating the sensor weighs as the noise model says (header).
    s.factor = std::max(s.factor, noise_.speed_factor(p.norm(), array_[i].max_speed.value_or(0.0)));
    s.time += dt;
    if (s.time >= options_.block - 1e-9 && repeats.repeats(i) == 0) {
      update(i, raw.t);
      s.clear_block();
    }
  }
  if (options_.gauge == SelfCalibrationGauge::kWheels && wheels) observe_wheels(raw, used, *wheels);
}

void SelfCalibration::observe_wheels(const ArraySample& raw, SensorMask used,
                                     const Twist2& wheels) {
  if (!wheels.vector().allFinite()) return;
  const real dt = raw.dt;
  const SelfCalibrationEstimate common = gauge();
  WheelGauge& w = wheel_;
  // The used sensors' point velocities (robot frame, m/s) corrected by their
  // relative calibration theta / (G, D) alone: u = R(yaw) R(delta - D)
  // diag(G / s) R(yaw)^T u_raw. Their fit is the array's twist in the
  // configured gauge, G R(-D) times the true one.
  for (int k = 0; k < n_; ++k) {
    if (!contains(used, k)) continue;
    const auto u = static_cast<std::size_t>(k);
    const SensorState& s = state_[u];
    const Vec2 u_raw = velocity_from_counts_[u] * raw.counts[u] / dt;
    w.factor =
        std::max(w.factor, noise_.speed_factor(u_raw.norm(), array_[k].max_speed.value_or(0.0)));
    const Mat2 r = rotation(array_[k].yaw);
    const Mat2 c_inv =
        rotation(s.theta.yaw_offset - common.yaw_offset) *
        Vec2(common.scale_x / s.theta.scale_x, common.scale_y / s.theta.scale_y).asDiagonal();
    points_.u[u] = r * c_inv * r.transpose() * u_raw;
    const real q = metres_per_count_[u] / dt;
    const real rel = options_.relative_noise * points_.u[u].norm();
    points_.info[u] = Mat2::Identity() / (q * q / 6.0 + rel * rel + 1e-12);
  }
  const auto fit = solver_.fit(used, points_);
  if (!fit) return;
  w.sum_v_array += fit->twist.v * dt;
  w.sum_theta_array += fit->twist.omega * dt;
  w.sum_v_wheels += wheels.v * dt;
  w.sum_theta_wheels += wheels.omega * dt;
  const Mat3& c = fit->covariance;
  w.sum_var += (0.5 * (c(0, 0) + c(1, 1)) + radius_ * radius_ * c(2, 2)) * dt * dt;
  w.time += dt;
  if (w.time >= options_.block - 1e-9) {
    update_gauge(raw.t);
    w.sum_v_array.setZero();
    w.sum_v_wheels.setZero();
    w.sum_theta_array = w.sum_theta_wheels = w.sum_var = w.time = 0.0;
    w.factor = 1.0;
  }
}

void SelfCalibration::update_gauge(double t) {
  WheelGauge& w = wheel_;
  // 1. The block's motion, m: a rotation moves the sensors by radius_ Theta.
  const real d = std::hypot(w.sum_v_wheels.norm(), radius_ * w.sum_theta_wheels);
  if (d < options_.min_speed * w.time) return;  // nothing excited
  // 2. Forgetting: the random walk since the last update, capped at the prior.
  if (w.last_update >= 0.0) {
    const real e = static_cast<real>(t - w.last_update);
    w.p.diagonal() += Vec2::Constant(e * options_.gauge_walk * options_.gauge_walk);
    const real cap = options_.prior_scale_sd * options_.prior_scale_sd;
    for (int k = 0; k < 2; ++k) {
      if (w.p(k, k) > cap) {
        const real f = std::sqrt(cap / w.p(k, k));
        w.p.row(k) *= f;
        w.p.col(k) *= f;
      }
    }
  }
  w.last_update = t;
  // 3. y = H k: (V_a, r Theta_a) against the wheels' (V_w, r Theta_w).
  const Vec3 y(w.sum_v_array.x(), w.sum_v_array.y(), radius_ * w.sum_theta_array);
  Mat<3, 2> h;
  h << w.sum_v_wheels.x(), -w.sum_v_wheels.y(),  //
      w.sum_v_wheels.y(), w.sum_v_wheels.x(),    //
      radius_ * w.sum_theta_wheels, 0.0;
  const Vec3 r = y - h * w.k;
  // 4. Measurement variance, m^2 per component.
  const real var =
      (options_.wheel_noise * options_.wheel_noise * d * d + w.sum_var) * w.factor + 1e-12;
  // 5. The core's gated update (kalman.hpp, Joseph form): a block whose
  // innovation fails the chi-square test at gross_alpha is the wheels
  // slipping grossly, not the gauge.
  if (!gated_update<2, 3>(w.k, w.p, r, h, Mat3(var * Mat3::Identity()), wheel_gate_).fused) return;
  w.p = 0.5 * (w.p + w.p.transpose()).eval();
  ++w.updates;
  // 6. The new common part to every sensor.
  fix_gauge();
  for (int j = 0; j < n_; ++j) renew(j);
}

void SelfCalibration::update(int i, double t) {
  SensorState& s = state_[static_cast<std::size_t>(i)];
  const Vec2 w = s.sum_pred;
  if (w.norm() < options_.min_speed * s.time) return;  // nothing excited
  // Forgetting: the random walk since the last update, capped at the prior.
  if (s.last_update >= 0.0) {
    const real e = static_cast<real>(t - s.last_update);
    // Capped at the prior, or at what it was when wider (after a reset).
    const Vec3 cap = Vec3(options_.prior_scale_sd * options_.prior_scale_sd,
                          options_.prior_scale_sd * options_.prior_scale_sd,
                          options_.prior_yaw_sd * options_.prior_yaw_sd)
                         .cwiseMax(s.p.diagonal());
    s.p.diagonal() +=
        e * Vec3(options_.scale_walk * options_.scale_walk,
                 options_.scale_walk * options_.scale_walk, options_.yaw_walk * options_.yaw_walk);
    for (int k = 0; k < 3; ++k) {
      if (s.p(k, k) > cap(k)) {
        const real f = std::sqrt(cap(k) / s.p(k, k));
        s.p.row(k) *= f;
        s.p.col(k) *= f;
      }
    }
  }
  const real elapsed = s.last_update >= 0.0 ? static_cast<real>(t - s.last_update) : 0.0;
  s.last_update = t;
  const real c = std::cos(s.theta.yaw_offset), sn = std::sin(s.theta.yaw_offset);
  const Vec2 rw(c * w.x() + sn * w.y(), -sn * w.x() + c * w.y());  // R(-delta) w
  const Vec2 h(s.theta.scale_x * rw.x(), s.theta.scale_y * rw.y());
  Mat<2, 3> hj;
  hj << rw.x(), 0.0, s.theta.scale_x * (-sn * w.x() + c * w.y()),  //
      0.0, rw.y(), s.theta.scale_y * (-c * w.x() - sn * w.y());
  const Vec2 r = s.sum_meas - h;
  const real mpc = metres_per_count_[static_cast<std::size_t>(i)];
  const real relative = options_.relative_noise * w.norm();
  const real var = (mpc * mpc / 3.0 + s.sum_var + relative * relative) * s.factor;
  // The core's gated update (kalman.hpp, Joseph form) of (s_x, s_y, delta):
  // a block whose innovation fails the chi-square test at gross_alpha
  // (S = H P H^T + R) is not this calibration: a gross error, unless it
  // persists as another calibration (the reset below).
  Vec3 x(s.theta.scale_x, s.theta.scale_y, s.theta.yaw_offset);
  const Mat2 noise = var * Mat2::Identity();
  Vec3 predicted = s.p.diagonal();  // theta's variance before the update
  bool fused = gated_update<3, 2>(x, s.p, r, hj, noise, block_gate_).fused;
  // The rejections' CUSUM (header, "Reset"): blocks rejected at more than
  // the test's false-alarm rate say the calibration is not this one. While
  // it is above zero the blocks are kept (sums); once it alarms, a
  // calibration that explains them all is looked for (reset()).
  s.rejections = std::max<real>(0.0, s.rejections + (fused ? llr_fused_ : llr_rejected_));
  if (s.rejections > 0.0) {
    s.run.add(w, s.sum_meas, var);
  } else {
    s.run = {};
  }
  if (!fused) {
    if (!(s.rejections > reset_h_ && reset(s))) return;
    predicted = s.p.diagonal();
    if (!gated_update<3, 2>(x, s.p, r, hj, noise, block_gate_).fused) return;
  }
  s.p = 0.5 * (s.p + s.p.transpose()).eval();
  ++s.updates;
  // The hold (docs/math.md, "The hold"): d, theta's own steps (this
  // update's x - theta, not the gauge's common moves) forgotten over
  // settle_time, d <- (1 - a)(d + step), a = min(1, elapsed / settle_time):
  // theta less its exponential average. While the filter's model holds (a
  // calibration that walks as scale_walk and yaw_walk say), theta is a
  // martingale: a step's variance is what the update takes off P's
  // diagonal, its prediction's less its posterior's (the walk since the
  // last update and what the block taught), so d's variance is v <- (1 -
  // a)^2 (v + P_pred - P_post). A scale beyond hold_z_ sqrt(v) holds the
  // sensor; below half of that, it is released. The yaw is not tested: its
  // covariance is overconfident (rms z 1.2-1.5 against the simulator's
  // truth), so its steps are larger than v says and a sound sensor would be
  // held far more often than hold_alpha (docs/self-calibration.md).
  const real a = std::min<real>(1.0, elapsed / options_.settle_time);
  const Vec3 step = x - Vec3(s.theta.scale_x, s.theta.scale_y, s.theta.yaw_offset);
  s.moved = (1.0 - a) * (s.moved + step);
  s.moved_var = (1.0 - a) * (1.0 - a) * (s.moved_var + (predicted - s.p.diagonal()).cwiseMax(0.0));
  const real hold = (s.settling ? 0.5 : 1.0) * hold_z_;
  s.settling = (s.moved.cwiseAbs2() - hold * hold * s.moved_var).head<2>().maxCoeff() > 0.0;
  s.theta = {x(0), x(1), x(2)};
  fix_gauge();
  for (int j = 0; j < n_; ++j) {
    SensorState& o = state_[static_cast<std::size_t>(j)];
    // The runaway test (header): each component's distance beyond its
    // tolerance in standard deviations of its estimate; out beyond +z,
    // back below -z.
    const Vec3 beyond(std::abs(o.theta.scale_x - 1.0) - options_.runaway_scale,
                      std::abs(o.theta.scale_y - 1.0) - options_.runaway_scale,
                      std::abs(o.theta.yaw_offset) - options_.runaway_yaw);
    const Vec3 z = beyond.cwiseQuotient(o.p.diagonal().cwiseMax(1e-18).cwiseSqrt());
    o.runaway = o.runaway ? z.maxCoeff() > -runaway_z_ : z.maxCoeff() > runaway_z_;
    renew(j);
  }
}

void SelfCalibration::RejectionRun::add(const Vec2& w, const Vec2& m, real var) {
  const real v = 1.0 / var;
  ww += v * w * w.transpose();
  mw += v * m * w.transpose();
  mm += v * m.squaredNorm();
  wx += v * (w.x() * m.y() - w.y() * m.x());
  ++blocks;
}

bool SelfCalibration::reset(SensorState& s) {
  // Do the run's blocks agree with one calibration (they are then the
  // sensor's new one, not a fault's)? m_k = M w_k + n_k, n_k ~ N(0, var_k I),
  // fitted by weighted least squares as one scale and rotation, M = a I + b J
  // (J the rotation by 90 degrees; 2 parameters), and, when that fails, as
  // any linear map M = (sum m w^T / v)(sum w w^T / v)^-1 (4 parameters: both
  // axes' scales, a yaw and a shear). Each fit's residual chi-square,
  // sum |m|^2 / v less what the fit explains, is tested at gross_alpha on
  // its 2 n - p degrees of freedom. Blocks of one calibration pass; a
  // fault's (a tracking loss, spikes) do not, and the run starts again. When
  // they agree, theta keeps its mean and its covariance is reset to the wide
  // prior (reset_scale_sd, reset_yaw_sd): the blocks from then on are fused
  // against it, and what a path along one direction does not excite keeps
  // its value.
  RejectionRun& run = s.run;
  if (run.blocks < 3) return false;
  const real tr = run.ww.trace();
  if (!(tr > 0.0)) return false;
  const real a = run.mw.trace() / tr, b = run.wx / tr;  // M = a I + b J
  bool agree = run.mm - (a * a + b * b) * tr <=
               static_cast<real>(chi2_quantile(1.0 - options_.gross_alpha, 2 * run.blocks - 2));
  if (!agree && run.ww.determinant() > 0.0) {
    const Mat2 m = run.mw * run.ww.inverse();
    agree = run.mm - (m * run.mw.transpose()).trace() <=
            static_cast<real>(chi2_quantile(1.0 - options_.gross_alpha, 2 * run.blocks - 4));
  }
  run = {};
  if (!agree) return false;
  s.p = Vec3(options_.reset_scale_sd, options_.reset_scale_sd, options_.reset_yaw_sd)
            .cwiseAbs2()
            .asDiagonal();
  s.rejections = 0.0;
  ++s.resets;
  return true;
}

void SelfCalibration::fix_gauge() {
  // The median over the sensors not run away of log sqrt(s_x s_y) and of
  // delta is set to the gauge's: the majority carries the common part.
  std::array<real, kMaxSensors> logs{}, yaws{};
  int m = 0;
  for (int j = 0; j < n_; ++j) {
    const SensorState& o = state_[static_cast<std::size_t>(j)];
    if (o.runaway) continue;
    logs[static_cast<std::size_t>(m)] = 0.5 * std::log(o.theta.scale_x * o.theta.scale_y);
    yaws[static_cast<std::size_t>(m)] = o.theta.yaw_offset;
    ++m;
  }
  if (m < 3) return;
  const auto median = [m](std::array<real, kMaxSensors>& v) {
    std::sort(v.begin(), v.begin() + m);
    const auto h = static_cast<std::size_t>(m / 2);
    return m % 2 == 1 ? v[h] : 0.5 * (v[h - 1] + v[h]);
  };
  const SelfCalibrationEstimate target = gauge();
  const real g = std::exp(std::log(target.scale_x) - median(logs)),
             d = median(yaws) - target.yaw_offset;
  for (int j = 0; j < n_; ++j) {
    SensorState& o = state_[static_cast<std::size_t>(j)];
    o.theta.scale_x *= g;
    o.theta.scale_y *= g;
    o.theta.yaw_offset -= d;
  }
}

SelfCalibrationEstimate SelfCalibration::applied_gauge() const {
  // The same test on the wheels' (G, D): with k = a + i b near (1, 0),
  // G - 1 ~ a - 1 and D ~ -b / a, variances P_aa and P_bb / a^2.
  const SelfCalibrationEstimate g = gauge();
  if (options_.gauge != SelfCalibrationGauge::kWheels || wheel_.updates == 0) return g;
  const real a = wheel_.k.x();
  const bool scaled = significant(apply_z_, g.scale_x - 1.0, wheel_.p(0, 0));
  const bool turned = significant(apply_z_, g.yaw_offset, wheel_.p(1, 1) / (a * a));
  return {scaled ? g.scale_x : 1.0, scaled ? g.scale_y : 1.0, turned ? g.yaw_offset : 0.0};
}

SelfCalibrationEstimate SelfCalibration::gauge() const {
  // k = a + i b = G e^(-iD) (kWheels); its prior (1, 0) is the configured gauge.
  const real a = wheel_.k.x(), b = wheel_.k.y();
  if (options_.gauge != SelfCalibrationGauge::kWheels || wheel_.updates == 0 ||
      !(std::isfinite(a) && std::isfinite(b) && a > 0.0)) {
    return {};
  }
  const real g = std::hypot(a, b);
  return {g, g, std::atan2(-b, a)};
}

}  // namespace moa
