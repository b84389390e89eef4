// Faults over time: a per-sensor health state with hysteresis, for faults
// one epoch's chi-square test cannot see.
//
// Per sensor i and epoch (counts c_i, point velocity u_i, robot frame m/s),
// one family of tests over time, on the normalised innovations:
//  - a sequential test (Page's CUSUM) of the residual against the
//    twist x_(i) of the other sensors used (leave-one-out, with its
//    covariance; the estimate itself when i was not used; the wheels' or
//    the hold's twist when fewer than two sensors remain), r = u_i - p,
//    p = A_i x_(i), whitened along and across the motion:
//      z_par  = e_par^T r / sqrt(e_par^T S e_par)   (scale error)
//      z_perp = e_perp^T r / sqrt(e_perp^T S e_perp) (yaw offset)
//    e_par = p / |p|, e_perp its normal, S = S_i + A_i C_(i) A_i^T the
//    noise model's covariance of the residual. Under the noise model each z
//    is N(0, 1) epoch after epoch; a fault shifts its mean. Four one-sided
//    statistics per sensor, g <- max(0, g + z - k) for z = +-z_par,
//    +-z_perp, each z clipped to +-sqrt(q(1 - alpha, 2)) (one gross error,
//    the consistency test's, moves g by a bounded step); an alarm when a g
//    exceeds h. k = drift_shift (in sd: half the smallest persistent shift
//    worth an exclusion, one sd); h from the mean time between false alarms
//    under the noise model, drift_false_alarm_time, by Siegmund's
//    approximation of the in-control run length of each statistic,
//      ARL0 = (exp(2 k h') - 2 k h' - 1) / (2 k^2),  h' = h + 1.166,
//    with ARL0 = 4 drift_false_alarm_time / dt (four statistics): at
//    100 Hz, one hour and k = 0.5, h = 12.3. A shift of mu sd is found
//    after about h / (mu - k) epochs (docs/math.md). Fed only on epochs where
//    |p| >= drift_min_speed, the sensor is not over its rating (there it
//    loses counts at random: gross errors, the consistency test's) and does
//    not flag its reading (low SQUAL, overflow: the noise model all but
//    ignores it); near the rating the noise model's wider covariance is in
//    S. Only the sensor with the largest
//    statistic may be newly excluded in an epoch (a bad sensor biases the
//    others' leave-one-out predictions too), and an exclusion restarts the
//    others' statistics, fed by that biased prediction.
//    An excluded sensor is still tested: the exponential means of its z_par
//    and z_perp, each clipped to +-2 k, over drift_release_time release it
//    once both are within k / 2 (1.6 sd of such a mean at 100 Hz and 0.2 s
//    under the noise model; a shift of 2 k keeps it out), after
//    drift_release_time of samples; its statistics then restart.
// Named outcomes. An alarm is named by the pattern of the sensor's last
// readings: frozen when its counts repeated exactly (not zero) for the last
// three epochs (a stopped register), zero when it read zero for the last
// three while some other sensor did not (a sensor off the floor or dead),
// drift otherwise (a resolution or yaw gone off). The names add no test and
// no threshold: the alarm is the CUSUM's, at its false-alarm rate, and comes
// only once the readings disagree with the motion (a register frozen in a
// perfectly steady cruise reads what a good sensor would, and costs nothing
// until the motion changes; the self-calibration does not learn from such
// runs, self_calibration.hpp). A frozen or zero sensor's hypothesis stands
// while its pattern holds (its counts still repeat, it still reads zero);
// the first fresh reading refutes it, and from there the release test
// judges it as it judges a drifting one, on drift_release_time of fresh
// samples. Nothing is latched.
// States: trusted -> suspect (a statistic over h / 2) -> excluded (an alarm;
// its name is kept) -> probation (released; out for probation seconds) ->
// trusted. Suspect sensors are used; excluded and probation ones are not.
// The alarm level follows from k, the false-alarm time and the noise model;
// k, the release window, the probation and drift_min_speed are chosen
// values (docs/math.md), none fitted to a scenario. Fixed-size state, no
// allocation.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cstdint>

#include "moa/core/array.hpp"
#include "moa/core/estimate.hpp"
#include "moa/core/names.hpp"
#include "moa/core/options_check.hpp"
#include "moa/core/robust_estimate.hpp"
#include "moa/core/subset.hpp"

namespace moa {

struct HealthOptions {
  bool enabled = true;
  real drift_min_speed = 0.05;  ///< m/s, predicted point speed for a drift sample
  real drift_shift = 0.5;       ///< k, sd: the CUSUM's reference (half the shift sought)
  /// s, mean time between false alarms of one sensor under the noise model
  real drift_false_alarm_time = 3600.0;
  real drift_release_time = 0.2;  ///< s, the release test's window
  real probation = 0.1;           ///< s an excluded sensor must behave before it is used again
  /// nullopt when usable, else the first field out of its bounds, its path
  /// relative to this struct (options_check.hpp).
  OptionCheck validate() const;
};

/// Counts equal to the synchroniser's rounding (1e-6 counts: a row off the
/// epoch grid by a rounding error leaves 1e-12 of its counts in the next
/// epoch): the repeat a frozen register makes.
inline bool same_counts(const Vec2& a, const Vec2& b) {
  return (a - b).cwiseAbs().maxCoeff() <= 1e-6 * std::max<real>(1.0, a.cwiseAbs().maxCoeff());
}

/// Epochs in a row whose counts repeat the epoch before's exactly (to 1e-6
/// counts: the synchroniser's rounding), not zero: the pattern a frozen
/// register reads. One counter per estimator: the health monitor names a
/// frozen alarm by it, the self-calibration guards its learning by it.
class RepeatCounter {
 public:
  /// Every sensor of `sample`, once per epoch.
  void count(const ArraySample& sample) {
    for (int i = 0; i < std::min(sample.size, kMaxSensors); ++i) {
      const auto k = static_cast<std::size_t>(i);
      const Vec2 c = sample.counts[k];
      repeats_[k] = !c.isZero() && same_counts(c, last_[k]) ? repeats_[k] + 1 : 0;
      last_[k] = c;
    }
  }
  /// Epochs sensor i's counts have repeated (0: they differ from the last).
  int repeats(int i) const { return repeats_[static_cast<std::size_t>(i)]; }

 private:
  std::array<Vec2, kMaxSensors> last_ = zeros<Vec2>();
  std::array<int, kMaxSensors> repeats_{};
};

enum class Health : std::uint8_t { kTrusted, kSuspect, kExcluded, kProbation };
template <>
struct EnumNames<Health> {
  static constexpr std::array<NameEntry<Health>, 4> kTable{{
      {Health::kTrusted, "trusted"},
      {Health::kSuspect, "suspect"},
      {Health::kExcluded, "excluded"},
      {Health::kProbation, "probation"},
  }};
};

class HealthMonitor {
 public:
  HealthMonitor(int sensors, HealthOptions options, real alpha);

  /// The alarms of the statistics fed so far, named by the epoch's counts,
  /// and the state machine.
  /// Returns the sensors that may be used; sets `excluded` for the others
  /// among `candidates` (kFrozen, kZero, kDrift or kProbation).
  /// `repeats`: the estimator's count of repeated readings, this epoch's
  /// counted (of the counts as read, before any correction).
  SensorMask screen(const ArraySample& sample, SensorMask candidates, const RepeatCounter& repeats,
                    std::array<Exclusion, kMaxSensors>& excluded);
  /// The drift test's update after an estimate from the sensors `used`.
  /// `reference`: the epoch's estimate when it was not the sensors' (the
  /// wheels' or the hold's, with the gyro's rotation; nullptr when none):
  /// a sensor whose leave-one-out fit has fewer than two others is tested
  /// against it (two sensors that disagree: which one is wrong), unless it
  /// is one of the reference's own (`reference->used`).
  void observe(const SubsetSolver& solver, const ArraySample& sample, const PointMeasurements& m,
               SensorMask used, SensorMask candidates,
               const std::array<std::uint8_t, kMaxSensors>& noise_flags,
               const TwistEstimate* reference = nullptr);

  Health health(int i) const { return state_[static_cast<std::size_t>(i)].health; }
  /// Why sensor i is excluded (kNone unless health(i) is kExcluded).
  Exclusion reason(int i) const {
    const SensorState& s = state_[static_cast<std::size_t>(i)];
    return s.health == Health::kExcluded ? s.reason : Exclusion::kNone;
  }

 private:
  struct SensorState {
    Health health = Health::kTrusted;
    Exclusion reason = Exclusion::kNone;
    double since = 0.0;             ///< s, when probation began
    int zeros = 0;                  ///< epochs in a row read zero while another sensor did not
    bool held = false;              ///< excluded as frozen or zero and the pattern still holds
    std::array<real, 4> g{};        ///< CUSUMs of +z_par, -z_par, +z_perp, -z_perp
    Vec2 mean{0.0, 0.0};            ///< release test: means of (z_par, z_perp)
    real weight = 0.0, time = 0.0;  ///< of the means; s of samples since excluded
  };
  real drift(const SensorState& s) const;
  /// h for epochs of dt s (computed once, on the first sample).
  void set_threshold(real dt);

  HealthOptions options_;
  real residual_gate_;
  real clip_;     ///< sqrt(q(1 - alpha, 2)), sd
  real h_ = 0.0;  ///< CUSUM alarm level, sd; 0 until the first sample
  int n_;
  std::array<SensorState, kMaxSensors> state_{};
};

}  // namespace moa
