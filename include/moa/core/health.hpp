// Faults over time: a per-sensor health state with hysteresis, for faults
// one epoch's chi-square test cannot see.
//
// Per sensor i and epoch (counts c_i, point velocity u_i, robot frame m/s):
//  - frozen: c_i exactly equal to the previous epoch's, not zero and at
//    least frozen_min_counts on an axis, for frozen_run epochs in a row,
//    while the predicted point velocity changed by frozen_change since the
//    run began (a constant rate while the others vary), or for
//    frozen_long_run epochs whatever the motion. A good sensor in a steady
//    cruise repeats too: at 0.3 m/s an HDNS-2051 row of 23 frames carries
//    about 0.3 counts of noise, so both axes repeat often (seen on the
//    faults-liftoff runs with the first rule alone, at 10 epochs); while its
//    point velocity changes by 0.02 m/s (6 counts per 10 ms epoch at
//    800 cpi) it cannot. In a cruise at constant speed only the long run
//    tells: the longest run of a good sensor's repeats (counts >= 4) on
//    simulator seeds 1-30 of cruise, sekimori-a, sekimori-b, differential
//    and guided was 22 epochs, and each epoch more about halved how often a
//    run reached it, so 40 (0.4 s) leaves a margin of 2^-18; a register
//    frozen in a cruise (one frame's counts repeated: faults-cruise) is out
//    after 0.4 s instead of 1 s. "Equal" is to 1e-6 counts: a row whose time
//    is off the epoch grid by a rounding error leaves a fraction of 1e-12
//    of its counts in the neighbouring epoch.
//  - zero: c_i = 0 while the predicted point speed |A_i x| is at least
//    zero_speed, for zero_run epochs in a row (the others move).
//  - drift: the relative residual against the twist x_(i) of the other
//    sensors used (leave-one-out; the estimate itself when i was not used),
//      rho_par  = p^T (u_i - p) / |p|^2      (scale error along the motion)
//      rho_perp = p x (u_i - p) / |p|^2      (yaw offset, rad)
//    with p = A_i x_(i), averaged by an exponential window of drift_tau
//    seconds (weights normalised, so the mean is unbiased from the start),
//    and by a short one of drift_step_tau seconds that sees a step of the
//    scale (a change of floor) before the long mean reaches drift_exclude.
//    Fed only on epochs where |p| >= drift_min_speed, the sensor's noise was
//    not inflated (over speed, low SQUAL, overflow) and its whitened
//    residual passes q(1 - alpha, 2): gross errors are the consistency
//    test's, drift is the slow part.
// States: trusted -> suspect (a test half-way: a repeat, a zero, the drift
// mean over drift_suspect) -> excluded (a test fires; the reason is kept)
// -> probation (the test no longer fires; the sensor stays out for
// probation seconds) -> trusted. Suspect sensors are used; excluded and
// probation ones are not. A drift exclusion is released when the mean falls
// under drift_release.
// Thresholds tuned on simulator seeds 1-100 (tests use 101+, docs 201+).
// Fixed-size state, no allocation.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>

#include "moa/core/array.hpp"
#include "moa/core/names.hpp"
#include "moa/core/options_check.hpp"
#include "moa/core/robust_estimate.hpp"
#include "moa/core/subset.hpp"

namespace moa {

struct HealthOptions {
  bool enabled = true;
  int frozen_run = 10;           ///< epochs of identical counts
  real frozen_min_counts = 4.0;  ///< counts on the larger axis
  real frozen_change = 0.02;     ///< m/s, change of the predicted point velocity
  int frozen_long_run = 40;      ///< epochs of identical counts, whatever the motion
  int zero_run = 5;              ///< epochs of zero counts while moving
  real zero_speed = 0.02;        ///< m/s, predicted point speed
  real drift_tau = 2.0;          ///< s, averaging window of the residual
  real drift_min_speed = 0.05;   ///< m/s, predicted point speed for a drift sample
  real drift_min_time = 0.5;     ///< s of drift samples before the test acts
  real drift_suspect = 0.015;    ///< relative scale or yaw (rad)
  real drift_exclude = 0.03;
  real drift_release = 0.01;
  /// A step (a change of floor) is seen sooner by a short window: its mean
  /// over drift_step_tau (s) beyond drift_step excludes too, once the
  /// window has drift_step_tau of samples.
  real drift_step_tau = 0.2;
  real drift_step = 0.06;
  real probation = 0.1;  ///< s an excluded sensor must behave before it is used again
  /// nullopt when usable, else the first field out of its bounds, its path
  /// relative to this struct (options_check.hpp).
  OptionCheck validate() const;
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

  /// Frozen and zero tests on the epoch's counts, then the state machine.
  /// Returns the sensors that may be used; sets `excluded` for the others
  /// among `candidates` (kFrozen, kZero, kDrift or kProbation).
  SensorMask screen(const SubsetSolver& solver, const ArraySample& sample, const Twist2& predicted,
                    SensorMask candidates, std::array<Exclusion, kMaxSensors>& excluded);
  /// The drift test's update after an estimate x from the sensors `used`.
  void observe(const SubsetSolver& solver, const ArraySample& sample, const PointMeasurements& m,
               const Twist2& x, SensorMask used, SensorMask candidates,
               const std::array<std::uint8_t, kMaxSensors>& noise_flags);

  Health health(int i) const { return state_[static_cast<std::size_t>(i)].health; }
  /// Window means of the relative residual (scale, yaw); 0 before any sample.
  real drift_scale(int i) const;
  real drift_yaw(int i) const;

 private:
  struct SensorState {
    Health health = Health::kTrusted;
    Exclusion reason = Exclusion::kNone;
    double since = 0.0;  ///< s, when probation began
    Vec2 last_counts{0.0, 0.0};
    Vec2 run_start{0.0, 0.0};  ///< m/s, predicted point velocity when the run began
    int repeats = 0, zeros = 0;
    real sum_par = 0.0, sum_perp = 0.0, weight = 0.0, time = 0.0;
    real step_par = 0.0, step_perp = 0.0, step_weight = 0.0;  ///< the short window's
  };
  real drift(const SensorState& s) const;
  real step(const SensorState& s) const;

  HealthOptions options_;
  real residual_gate_;
  int n_;
  std::array<SensorState, kMaxSensors> state_{};
};

}  // namespace moa
