#include "moa/core/health.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <optional>

#include "moa/core/chi2.hpp"
#include "moa/core/cusum.hpp"

namespace moa {

OptionCheck HealthOptions::validate() const {
  OptionsCheck c;
  c.non_negative("drift_min_speed", drift_min_speed)
      .positive("drift_shift", drift_shift)
      .positive("drift_false_alarm_time", drift_false_alarm_time)
      .positive("drift_release_time", drift_release_time)
      .non_negative("probation", probation);
  return c.result();
}

HealthMonitor::HealthMonitor(int sensors, HealthOptions options, real alpha)
    : options_(options),
      residual_gate_(static_cast<real>(chi2_quantile(1.0 - alpha, 2))),
      clip_(std::sqrt(residual_gate_)),
      n_(sensors) {}

void HealthMonitor::set_threshold(real dt) {
  // Four statistics per sensor: ARL0 = 4 T / dt samples (cusum.hpp).
  h_ = cusum_threshold(options_.drift_shift, 4.0 * options_.drift_false_alarm_time / dt);
}

real HealthMonitor::drift(const SensorState& s) const {
  return *std::max_element(s.g.begin(), s.g.end());
}

SensorMask HealthMonitor::screen(const ArraySample& sample, SensorMask candidates,
                                 const RepeatCounter& repeats,
                                 std::array<Exclusion, kMaxSensors>& excluded) {
  SensorMask allowed = candidates;
  if (!options_.enabled) return allowed;
  // One bad sensor biases the leave-one-out twists the others are judged
  // against, so their drift statistics rise with its own (by about 1/(N-1)
  // of it): only the largest of them may be newly excluded as drift, and
  // the others then restart.
  real largest_drift = 0.0;
  for (int i = 0; i < n_; ++i) {
    const SensorState& s = state_[static_cast<std::size_t>(i)];
    if (contains(candidates, i) && s.health != Health::kExcluded) {
      largest_drift = std::max(largest_drift, drift(s));
    }
  }
  int newly_drifting = -1;
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
  // Three readings alike name an alarm frozen or zero (health.hpp).
  constexpr int kPattern = 2;
  for (int i = 0; i < n_; ++i) {
    const auto k = static_cast<std::size_t>(i);
    SensorState& s = state_[k];
    const Vec2 c = sample.counts[k];
    const int repeated = repeats.repeats(i);
    if (!all_zero) s.zeros = c.isZero() ? s.zeros + 1 : 0;
    if (!contains(candidates, i)) continue;  // lifted: nothing to judge
    const bool out = s.health == Health::kExcluded;
    // A frozen or zero hypothesis stands while its pattern holds; the first
    // fresh reading refutes it, and the release test starts on fresh samples.
    if (out && s.held &&
        !(s.reason == Exclusion::kFrozen ? repeated > 0 : s.zeros > 0 || all_zero)) {
      s.held = false;
      s.mean.setZero();
      s.weight = s.time = 0.0;
    }
    const real d = drift(s);
    const bool released = out && !s.held && s.time >= options_.drift_release_time &&
                          s.weight > 0.0 &&
                          (s.mean / s.weight).cwiseAbs().maxCoeff() < 0.5 * options_.drift_shift;
    Exclusion bad = Exclusion::kNone;
    if (out && !released) {
      bad = s.reason;
    } else if (!out && h_ > 0.0 && d > h_ && d >= largest_drift && newly_drifting < 0) {
      // A new alarm, named by the readings that raised it.
      bad = repeated >= kPattern  ? Exclusion::kFrozen
            : s.zeros >= kPattern ? Exclusion::kZero
                                  : Exclusion::kDrift;
      newly_drifting = i;
      // The statistics restart (they were the fault's) and the release test
      // begins; a frozen or zero sensor's only once its pattern is broken.
      s.g.fill(0.0);
      s.mean.setZero();
      s.weight = s.time = 0.0;
      s.held = bad != Exclusion::kDrift;
    }
    if (released) s.g.fill(0.0);
    const bool half = h_ > 0.0 && d > 0.5 * h_;
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
        if (bad == Exclusion::kNone) {
          s.health = Health::kProbation;
          s.since = sample.t;
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
  if (newly_drifting >= 0) {
    for (int i = 0; i < n_; ++i) {
      if (i != newly_drifting) state_[static_cast<std::size_t>(i)].g.fill(0.0);
    }
  }
  return allowed;
}

void HealthMonitor::observe(const SubsetSolver& solver, const ArraySample& sample,
                            const PointMeasurements& m, SensorMask used, SensorMask candidates,
                            const std::array<std::uint8_t, kMaxSensors>& noise_flags,
                            const TwistEstimate* reference) {
  if (!options_.enabled || !(sample.dt > 0.0)) return;
  if (h_ == 0.0) set_threshold(static_cast<real>(sample.dt));
  const real k = options_.drift_shift;
  const real a = std::min<real>(1.0, sample.dt / options_.drift_release_time);
  for (int i = 0; i < n_; ++i) {
    const auto u = static_cast<std::size_t>(i);
    // Near its rating a sensor is tested with the noise model's wider
    // covariance (in S), as the consistency test does. Over the rating
    // itself it fails by losing counts at random (gross errors, not a
    // shift: the consistency test's), and a reading the sensor flags itself
    // (low SQUAL, overflow) the noise model already all but ignores: this
    // test watches the readings a sensor vouches for.
    constexpr std::uint8_t kNotFed = kNoiseOverRating | kNoiseLowSqual | kNoiseOverflow;
    if (!contains(candidates, i) || (noise_flags[u] & kNotFed)) continue;
    SensorState& s = state_[u];
    // Frozen or zero and still so: the release test waits for a fresh reading.
    if (s.held) continue;
    // The twist of the others and its covariance: leave-one-out when i was
    // used and enough remain, else the estimate's, else the reference's (not
    // for a sensor the reference was made with: it would test it against
    // itself).
    const SensorMask others = used & ~(SensorMask{1} << i);
    const SensorMask from = contains(used, i) ? others : used;
    std::optional<SubsetFit> fit;
    if (count_sensors(from) >= 2) {
      fit = solver.fit(from, m);
    } else if (reference != nullptr && !contains(reference->used, i)) {
      fit = SubsetFit{reference->twist, reference->covariance};
    }
    if (!fit) continue;
    const Mat<2, 3>& j = solver.jacobian(i);
    const Vec2 p = j * fit->twist.vector();
    const real speed = p.norm();
    if (!(speed >= options_.drift_min_speed) || speed == 0.0) continue;
    const Mat2 cov = m.info[u].inverse() + j * fit->covariance * j.transpose();
    const Vec2 e_par = p / speed, e_perp(-e_par.y(), e_par.x());
    const Vec2 r = m.u[u] - p;
    const real v_par = e_par.dot(cov * e_par), v_perp = e_perp.dot(cov * e_perp);
    if (!(v_par > 0.0 && v_perp > 0.0)) continue;
    const Vec2 z = Vec2(e_par.dot(r) / std::sqrt(v_par), e_perp.dot(r) / std::sqrt(v_perp))
                       .cwiseMax(-clip_)
                       .cwiseMin(clip_);
    if (s.health == Health::kExcluded) {
      // The release test: exponential means of z clipped to +-2k, the shift
      // sought (beyond it a sample says "shifted" no louder, so the mean
      // forgets a gross fault within about drift_release_time ln 4).
      s.mean = (1.0 - a) * s.mean + a * z.cwiseMax(-2.0 * k).cwiseMin(2.0 * k);
      s.weight = (1.0 - a) * s.weight + a;
      s.time += static_cast<real>(sample.dt);
      continue;
    }
    const std::array<real, 4> zs{z.x(), -z.x(), z.y(), -z.y()};
    for (std::size_t c = 0; c < 4; ++c) s.g[c] = std::max<real>(0.0, s.g[c] + zs[c] - k);
  }
}

}  // namespace moa
