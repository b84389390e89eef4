// Online self-calibration of the array (docs/self-calibration.md): each
// sensor's scale on both of its axes and its yaw offset relative to its
// configured mount, estimated recursively while driving from the array's
// redundancy (N >= 3) and applied to its counts before the estimator.
//
// Model, in sensor i's configured frame (before mirroring, so that a
// mirrored sensor reads the same): with w = R(yaw_i)^T u_i the true point
// velocity and m the velocity read through the configured mount,
//   m = C(theta_i) w,   C = diag(s_x, s_y) R(-delta),   theta_i = (s_x, s_y, delta)
// (the true sensor has scale s times the configured one and sits at
// yaw_i + delta). The correction applied to the counts is C^-1.
//
// Measurement: w is predicted from the twist x_(i) of the other sensors used
// by the estimate (leave-one-out; all of them when i itself was left out),
// corrected by their current calibration: w_pred = R(yaw_i)^T A_i x_(i).
// Displacements are summed over a block (block seconds) of epochs where
// both are valid (the relation is linear in w, so sums keep it and the
// quantisation of the counts does not grow), then one extended Kalman
// update per sensor with the random-walk state theta (forgetting: process
// noise scale_walk^2, yaw_walk^2 per second, the covariance capped at the
// prior's). A block is used only when it excites something: the predicted
// displacement at least min_speed * block; the Jacobian
//   H = [[ (R(-delta) w)_x, 0, s_x (-sin delta w_x + cos delta w_y) ],
//        [ 0, (R(-delta) w)_y, s_y (-cos delta w_x - sin delta w_y) ]]
// carries the rest: motion along the sensor's x axis informs s_x and delta,
// along y s_y and delta. Not used: epochs without a mice estimate, or where
// the sensor was lifted, frozen, zero, faulty or its noise was inflated (over
// speed, low SQUAL, overflow: a sensor over its rating under-reads by random
// fractions, which is a fault, not a calibration), blocks whose relative
// residual |m - C w| / |w| exceeds `gate`.
//
// Gauge: a common isotropic scale of all sensors is a rigid twist scaled,
// invisible to any redundancy; a common yaw offset is invisible in
// translation (it rotates v) and only weakly visible in rotation. Both are
// fixed by the majority: after every update the median over the sensors of
// log sqrt(s_x s_y) is removed from every scale and the median delta from
// every delta, so one drifting sensor among four is recovered whole.
//
// A sensor whose estimate runs away (|s - 1| > runaway_scale on an axis or
// |delta| > runaway_yaw) is reported by runaway() and left out of the
// estimate (Exclusion::kCalibration) until it is back within 0.8 times the
// bounds; it is still calibrated meanwhile. A calibration so far off that
// every block is over the gate (a resolution 50 % off, a sensor turned by
// 30 degrees) is reacquired: reacquire_blocks such blocks in a row that
// agree on one scale rho and rotation phi (m ~ rho R(phi) C w; the sd of
// their log rho and phi under reacquire_spread) restart the estimate there,
// with the prior's covariance; then it runs away as above.
//
// Deadband: an estimate is applied only once it is deadband (2 %, 0.02 rad)
// away from the configured value, or, for the scales, once their isotropic
// part g = sqrt(s_x s_y) is isotropic_deadband (1.25 %) away from 1 (then g
// is applied to both axes); once an axis is beyond the wide band both axes
// take their own estimates (a sensor plainly off). The estimates of
// good sensors deviate by up to 1 % on an axis on a path that drives
// forward only (sekimori-a, cruise): such a translation leaves one
// direction of (s_x, s_y, delta) to rotation, where a mount position error
// of 0.14 mm at 0.1 m reads as 0.14 % of tangential scale, which the
// three-parameter model cannot tell apart; applying every estimate cost 349
// mm on average on cruise (seeds 1-10, about 130 mm without). That scatter
// is mostly one axis against the other, while a drift (dust) dims both
// alike: hence the narrower isotropic band (docs/self-calibration.md).
// Within the bands the counts are used as configured, so a clean log gives
// the same odometry.
//
// Fixed-size state, no allocation: runs in the heap-free core.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>

#include "moa/core/array.hpp"
#include "moa/core/robust_estimate.hpp"
#include "moa/core/subset.hpp"

namespace moa {

struct SelfCalibrationOptions {
  bool enabled = false;
  real block = 0.1;       ///< s of epochs summed per update
  real min_speed = 0.05;  ///< m/s, mean predicted point speed of a block
  /// 1/sqrt(s), random walk of a scale (forgetting). Tuned on faults-drift
  /// and sekimori-a seeds 1-2: 0.003 lagged a 10 % drift over 6 s enough to
  /// cost 30-57 mm (the health monitor no longer excludes the corrected
  /// sensor); 0.01 gave 9.2 / 11.6 mm against 9.1 / 6.6 mm without.
  real scale_walk = 0.01;
  real yaw_walk = 0.0003;       ///< rad/sqrt(s), random walk of the yaw offset
  real prior_scale_sd = 0.05;   ///< sd of the initial scale; the covariance cap
  real prior_yaw_sd = 0.02;     ///< rad, sd of the initial yaw offset; the cap
  real relative_noise = 0.003;  ///< sd of a block's displacement, fraction of it
  /// An estimate within this of 1 (scale) or 0 (yaw offset, rad) is not
  /// applied: the configured value stands (docs/self-calibration.md).
  real deadband = 0.02;
  /// An isotropic part sqrt(s_x s_y) further than this from 1 is applied to
  /// both axes when each is within `deadband` (dust dims both axes
  /// alike; the good sensors' scatter is mostly one axis against the other).
  real isotropic_deadband = 0.0125;
  real gate = 0.3;  ///< relative residual above which a block is not used
  /// An epoch is not used for sensor i when the other sensors' fit fails
  /// the chi-square test at this level (they disagree among themselves).
  real predictor_alpha = 0.001;
  real runaway_scale = 0.25;  ///< |s - 1| beyond which a sensor is excluded
  real runaway_yaw = 0.2;     ///< rad, |delta| beyond which a sensor is excluded
  /// Blocks over `gate` in a row, read as one scale and rotation against the
  /// prediction, that restart a sensor's estimate there when they agree
  /// (a calibration far off: docs/self-calibration.md "Runaway").
  int reacquire_blocks = 20;
  real reacquire_spread = 0.05;  ///< sd of their log scale and rotation (rad) that agrees
  real apply_step = 5e-4;        ///< change of an estimate that renews the applied correction
  /// Empty when usable, else what is wrong, naming the field.
  const char* validate() const;
};

/// One sensor's calibration relative to its configured mount.
struct SelfCalibrationEstimate {
  real scale_x = 1.0, scale_y = 1.0;  ///< 1: as configured
  real yaw_offset = 0.0;              ///< rad
};

class SelfCalibration {
 public:
  SelfCalibration(const SensorArray& array, SelfCalibrationOptions options);

  /// Applies each sensor's correction to the counts of `sample` (in place).
  /// The applied correction changes only when an estimate moved by
  /// apply_step, so counts repeated by a frozen register stay identical.
  void correct(ArraySample& sample) const;

  /// Updates from one epoch: `raw` the uncorrected counts, `estimate` the
  /// estimator's output on the corrected counts.
  void observe(const ArraySample& raw, const RobustEstimate& estimate);

  /// The filter's estimate (theta) of sensor i.
  const SelfCalibrationEstimate& calibration(int i) const {
    return state_[static_cast<std::size_t>(i)].theta;
  }
  /// What is applied to sensor i's counts: the estimate where it is outside
  /// the deadbands, else as configured (1, 1, 0).
  const SelfCalibrationEstimate& applied(int i) const {
    return state_[static_cast<std::size_t>(i)].applied;
  }
  /// Standard deviations of (scale_x, scale_y, yaw_offset).
  Vec3 sd(int i) const;
  /// Blocks used for sensor i so far.
  long updates(int i) const { return state_[static_cast<std::size_t>(i)].updates; }
  /// Times sensor i's estimate was restarted from blocks over the gate.
  long reacquired(int i) const { return state_[static_cast<std::size_t>(i)].reacquired; }
  /// The estimate ran away: the sensor is left out (kCalibration).
  bool runaway(int i) const { return state_[static_cast<std::size_t>(i)].runaway; }
  SensorMask runaways() const;
  /// The health monitor excluded sensor i as drift and its correction is
  /// applied: it stays out (Exclusion::kDrift) until the correction is back
  /// to as configured. A sensor that changed enough to be excluded is not
  /// trusted back on a correction whose own error (0.3-0.7 %, the filter's
  /// scatter) would bias the rotation: on selfcal-step it cost 7 mm.
  bool held_as_drift(int i) const;
  int size() const { return n_; }

 private:
  /// Blocks over the gate in a row: running mean and sum of squared
  /// deviations of (log rho, phi) (reacquire()).
  struct GrossRun {
    int blocks = 0;
    Vec2 mean{0.0, 0.0}, m2{0.0, 0.0};
  };
  struct SensorState {
    SelfCalibrationEstimate theta;
    SelfCalibrationEstimate renewed;  ///< theta when the correction was last renewed
    SelfCalibrationEstimate applied;  ///< theta through the deadbands: in the correction
    Mat3 p = Mat3::Zero();
    Vec2 sum_meas{0.0, 0.0}, sum_pred{0.0, 0.0};  ///< m, configured sensor frame
    real sum_var = 0.0;                           ///< m^2, prediction variance
    real time = 0.0;                              ///< s in the block
    double last_update = -1.0;                    ///< s; < 0: never
    long updates = 0;
    bool runaway = false;
    long reacquired = 0;   ///< restarts by reacquire()
    bool drifted = false;  ///< excluded as drift since the correction was last 1, 1, 0
    GrossRun gross;        ///< the blocks over the gate in a row
    Mat2 correction = Mat2::Identity();  ///< counts -> corrected counts
  };
  void update(int i, double t);
  /// True when theta was restarted.
  bool reacquire(SensorState& s, const Vec2& h);
  void fix_gauge();
  void renew(int i);

  SelfCalibrationOptions options_;
  int n_;
  SensorArray array_;
  SubsetSolver solver_;
  std::array<Mat2, kMaxSensors> velocity_from_counts_ = zeros<Mat2>();
  std::array<real, kMaxSensors> metres_per_count_{};
  std::array<real, 2 * kMaxSensors> chi2_gate_{};  ///< by degrees of freedom
  std::array<SensorState, kMaxSensors> state_{};
  PointMeasurements points_;
};

}  // namespace moa
