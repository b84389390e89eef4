#include "moa/core/health.hpp"

#include <algorithm>
#include <cmath>

#include "moa/core/chi2.hpp"

namespace moa {

OptionCheck HealthOptions::validate() const {
  OptionsCheck c;
  c.at_least("frozen_run", frozen_run, 2)
      .non_negative("frozen_min_counts", frozen_min_counts)
      .non_negative("frozen_change", frozen_change)
      .at_least("frozen_long_run", frozen_long_run, frozen_run)
      .at_least("zero_run", zero_run, 1)
      .non_negative("zero_speed", zero_speed)
      .positive("drift_tau", drift_tau)
      .non_negative("drift_min_speed", drift_min_speed)
      .non_negative("drift_min_time", drift_min_time)
      .non_negative("drift_release", drift_release)
      .at_least_field("drift_suspect", drift_suspect, "drift_release", drift_release)
      .at_least_field("drift_exclude", drift_exclude, "drift_suspect", drift_suspect)
      .positive("drift_step_tau", drift_step_tau)
      .non_negative("drift_step", drift_step)
      .non_negative("probation", probation);
  return c.result();
}

HealthMonitor::HealthMonitor(int sensors, HealthOptions options, real alpha)
    : options_(options),
      residual_gate_(static_cast<real>(chi2_quantile(1.0 - alpha, 2))),
      n_(sensors) {}

real HealthMonitor::drift(const SensorState& s) const {
  if (s.weight <= 0.0 || s.time < options_.drift_min_time) return 0.0;
  return std::max(std::abs(s.sum_par), std::abs(s.sum_perp)) / s.weight;
}

real HealthMonitor::step(const SensorState& s) const {
  if (s.step_weight <= 0.0 || s.time < options_.drift_step_tau) return 0.0;
  return std::max(std::abs(s.step_par), std::abs(s.step_perp)) / s.step_weight;
}

real HealthMonitor::drift_scale(int i) const {
  const SensorState& s = state_[static_cast<std::size_t>(i)];
  return s.weight > 0.0 ? s.sum_par / s.weight : 0.0;
}

real HealthMonitor::drift_yaw(int i) const {
  const SensorState& s = state_[static_cast<std::size_t>(i)];
  return s.weight > 0.0 ? s.sum_perp / s.weight : 0.0;
}

SensorMask HealthMonitor::screen(const SubsetSolver& solver, const ArraySample& sample,
                                 const Twist2& predicted, SensorMask candidates,
                                 std::array<Exclusion, kMaxSensors>& excluded) {
  SensorMask allowed = candidates;
  if (!options_.enabled) return allowed;
  const Vec3 x = predicted.vector();
  // One bad sensor biases the leave-one-out twists the others are judged
  // against, so their drift statistics rise with its own (by about 1/(N-1)
  // of it): only the largest of them may be newly excluded as drift.
  real largest_drift = 0.0, largest_step = 0.0;
  for (int i = 0; i < n_; ++i) {
    if (contains(candidates, i)) {
      const SensorState& s = state_[static_cast<std::size_t>(i)];
      largest_drift = std::max(largest_drift, drift(s));
      largest_step = std::max(largest_step, step(s));
    }
  }
  // Zero is a fault of one sensor among others that move: when every
  // candidate reads zero together the array either stands still or lost the
  // floor as a whole, which is the consensus's common-mode test to judge
  // against the references; the zero runs then neither grow nor restart.
  bool all_zero = true;
  for (int i = 0; i < n_; ++i) {
    if (contains(candidates, i) && !sample.counts[static_cast<std::size_t>(i)].isZero()) {
      all_zero = false;
    }
  }
  for (int i = 0; i < n_; ++i) {
    const auto k = static_cast<std::size_t>(i);
    SensorState& s = state_[k];
    const Vec2 c = sample.counts[k];
    const Vec2 p = solver.jacobian(i) * x;  // predicted point velocity, m/s
    // Frozen: exact repeats (to 1e-6 counts: the synchroniser's rounding)
    // of a count large enough to carry noise.
    const real big = c.cwiseAbs().maxCoeff();
    if ((c - s.last_counts).cwiseAbs().maxCoeff() <= 1e-6 * std::max<real>(1.0, big) &&
        big >= options_.frozen_min_counts) {
      ++s.repeats;
    } else {
      s.repeats = 0;
      s.run_start = p;
    }
    s.last_counts = c;
    const int run = s.repeats + 1;  // epochs with these counts
    // Once found frozen it stays so while the counts keep repeating.
    const bool was_frozen = s.health == Health::kExcluded && s.reason == Exclusion::kFrozen;
    const bool frozen = run >= options_.frozen_long_run ||
                        (run >= options_.frozen_run &&
                         (was_frozen || (p - s.run_start).norm() >= options_.frozen_change));
    // Zero while the point should move.
    const real speed = p.norm();
    if (!all_zero) s.zeros = c.isZero() && speed >= options_.zero_speed ? s.zeros + 1 : 0;
    if (!contains(candidates, i)) continue;  // lifted: nothing to judge
    const real d = drift(s), f = step(s);
    Exclusion bad = Exclusion::kNone;
    if (frozen) {
      bad = Exclusion::kFrozen;
    } else if (s.zeros >= options_.zero_run) {
      bad = Exclusion::kZero;
    } else if ((d > options_.drift_exclude && d >= largest_drift) ||
               (f > options_.drift_step && f >= largest_step)) {
      bad = Exclusion::kDrift;
    }
    if (bad == Exclusion::kFrozen || bad == Exclusion::kZero) {
      // The residuals fed before the test fired were the fault's, not a
      // drift's: the windows start again when the sensor comes back.
      s.sum_par = s.sum_perp = s.weight = s.time = 0.0;
      s.step_par = s.step_perp = s.step_weight = 0.0;
    }
    const bool half = s.repeats >= 1 || s.zeros >= 1 || d > options_.drift_suspect;
    switch (s.health) {
      case Health::kTrusted:
      case Health::kSuspect:
        if (bad != Exclusion::kNone) {
          s.health = Health::kExcluded;
          s.reason = bad;
        } else {
          s.health = half ? Health::kSuspect : Health::kTrusted;
        }
        break;
      case Health::kExcluded:
        if (bad == Exclusion::kNone &&
            (s.reason != Exclusion::kDrift ||
             (d < options_.drift_release && f < options_.drift_release))) {
          s.health = Health::kProbation;
          s.since = sample.t;
        } else if (bad != Exclusion::kNone) {
          s.reason = bad;
        }
        break;
      case Health::kProbation:
        if (bad != Exclusion::kNone) {
          s.health = Health::kExcluded;
          s.reason = bad;
        } else if (sample.t - s.since >= options_.probation && !half) {
          s.health = Health::kTrusted;
        }
        break;
    }
    if (s.health == Health::kExcluded || s.health == Health::kProbation) {
      allowed &= ~(SensorMask{1} << i);
      excluded[k] = s.health == Health::kExcluded ? s.reason : Exclusion::kProbation;
    }
  }
  return allowed;
}

void HealthMonitor::observe(const SubsetSolver& solver, const ArraySample& sample,
                            const PointMeasurements& m, const Twist2& x, SensorMask used,
                            SensorMask candidates,
                            const std::array<std::uint8_t, kMaxSensors>& noise_flags) {
  if (!options_.enabled) return;
  const real a = std::min(1.0, sample.dt / options_.drift_tau);       // window weight of this epoch
  const real b = std::min(1.0, sample.dt / options_.drift_step_tau);  // the short window's
  for (int i = 0; i < n_; ++i) {
    const auto k = static_cast<std::size_t>(i);
    if (!contains(candidates, i) || noise_flags[k] != 0) continue;
    // Out for another reason (frozen, zero): its residual says nothing of drift.
    if (state_[k].health == Health::kExcluded && state_[k].reason != Exclusion::kDrift) continue;
    // The twist of the others: leave-one-out when i was used and enough remain.
    Vec3 xi = x.vector();
    const SensorMask others = used & ~(SensorMask{1} << i);
    if (contains(used, i)) {
      if (count_sensors(others) < 2) continue;
      // The twist alone (no chi-square, no covariance): bit for bit fit()'s.
      const auto twist = solver.twist(others, m);
      if (!twist) continue;
      xi = twist->vector();
    }
    const Vec2 p = solver.jacobian(i) * xi;
    const real p2 = p.squaredNorm();
    if (p2 < options_.drift_min_speed * options_.drift_min_speed) continue;
    const Vec2 r = m.u[k] - p;
    // A gross error (a spike, a lost frame) is not drift: left out when it is
    // both beyond the epoch's chi-square gate and over a quarter of the point's
    // displacement. A step of the scale (a change of floor, 10 %) is beyond
    // the gate at speed yet is what this test is for: it stays in.
    if (r.dot(m.info[k] * r) > residual_gate_ && r.squaredNorm() > 0.0625 * p2) continue;
    SensorState& s = state_[k];
    s.sum_par = (1.0 - a) * s.sum_par + a * p.dot(r) / p2;
    s.sum_perp = (1.0 - a) * s.sum_perp + a * (p.x() * r.y() - p.y() * r.x()) / p2;
    s.weight = (1.0 - a) * s.weight + a;
    s.step_par = (1.0 - b) * s.step_par + b * p.dot(r) / p2;
    s.step_perp = (1.0 - b) * s.step_perp + b * (p.x() * r.y() - p.y() * r.x()) / p2;
    s.step_weight = (1.0 - b) * s.step_weight + b;
    s.time += sample.dt;
  }
}

}  // namespace moa
