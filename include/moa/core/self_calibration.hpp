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
// the sensor was lifted, frozen, zero, faulty, its SQUAL low or its counts
// overflowed, blocks with an epoch over the sensor's rating (it loses counts
// at random there: the noise model's gross error, which the health monitor
// does not test either). Near its rating a sensor weighs as the estimators'
// noise model says: the block's variance times the largest speed factor m
// of its epochs (NoiseModelOptions::speed_factor, at most speed_cap).
//
// Gate: each block is one gated update (kalman.hpp): innovation r = m - C w,
// S = H P H^T + R with R = ((m per count)^2 / 3 + the prediction's variance +
// (relative_noise |w|)^2) I times the speed factor; fused when
// r^T S^-1 r <= q(1 - gross_alpha, 2), else rejected (a gross block: a
// spike, a slip, or a calibration that is no longer this one).
//
// Reset: rejections at more than gross_alpha say the calibration is not
// this one (a step of the resolution, a wrong cpi in the config, a sensor
// turned on its mount). Page's CUSUM of the log-likelihood ratio of
// rejection rate reset_rate against gross_alpha,
//   g <- max(0, g + ln(reset_rate / gross_alpha))                 (rejected)
//   g <- max(0, g + ln((1 - reset_rate) / (1 - gross_alpha)))     (fused),
// alarms at h = ln(reset_false_alarm_time / block): by Lorden's bound the
// mean run length without a fault is at least e^h blocks, so a false alarm
// comes at most once per reset_false_alarm_time of driving. Defaults: 6.21
// per rejection, -0.69 per fused block, h = 10.49: two rejected blocks in a
// row alarm; a rejection rate of 50 % alarms after about h / 2.76 = 3.8
// blocks on average, any rate over 10 % eventually. An alarm is not yet a
// reset: the blocks since g left zero must agree with one calibration
// (reset(): a least-squares fit as one scale and rotation, else as any
// linear map, its residual chi-square at gross_alpha); a fault's blocks (a
// tracking loss, spikes) do not, and the run starts again. When they
// agree, theta keeps its mean and its covariance is reset to the wide
// prior (reset_scale_sd, reset_yaw_sd), so the next blocks are fused and
// pull it to the new calibration; a direction the path does not excite
// keeps its value.
//
// Gauge: a common isotropic scale of all sensors is a rigid twist scaled,
// invisible to any redundancy; a common yaw offset is invisible in
// translation (it rotates v) and only weakly visible in rotation. After
// every update the median over the sensors of log sqrt(s_x s_y) and of
// delta is set to the gauge's (log G, D), so one drifting sensor among four
// is recovered whole; the relative calibration comes from the redundancy
// alone. `gauge` chooses (G, D):
// - kSensors (default): (1, 0), the majority keeps its configured scale and
//   yaw.
// - kWheels: the array's common scale G and yaw offset D measured against the
//   wheels' twist, (1, 0) until the wheels told something (so without wheels
//   it is kSensors). Let x_a = (v_a, omega_a) be the least-squares twist of
//   the sensors the estimate used (robot frame, m/s and rad/s), from counts
//   corrected by the relative calibration theta_i / (G, D) (median 1, 0),
//   and x_w the wheels' twist averaged over the same epoch. All sensors
//   reading G R(-D) times the true point velocity (each at yaw + D, its
//   counts times G) give
//     v_a = G R(-D) v_w,   omega_a = G cos(D) omega_w
//   (the radial field G sin(D) omega p_i a common yaw adds in rotation
//   projects onto v and omega only through the array's centroid, zero for a
//   symmetric array; neglected). As complex numbers, k = a + i b =
//   G e^(-iD) with the 2-state linear model, per block of `block` s of
//   epochs summed (V = sum v dt in m, Theta = sum omega dt in rad, robot
//   frame at each epoch, so the sums keep the relation):
//     [V_a,x]   [V_w,x     -V_w,y] [a]
//     [V_a,y] = [V_w,y      V_w,x] [b]
//     [r Th_a]  [r Th_w     0    ]
//   with r (m) the sensors' rms distance from the robot origin (a rotation
//   moves the points by r Theta). A Kalman filter on (a, b) with random walk
//   gauge_walk^2 per second on each (a floor change dims all sensors alike),
//   capped at the prior (prior_scale_sd), measurement variance
//   (wheel_noise d)^2 + the array twist's, d = sqrt(|V_w|^2 + (r Th_w)^2)
//   (m), times the block's largest speed factor of a used sensor (as
//   above); G = |k|, D = atan2(-b, a). Observable: translation tells both a and
//   b (scale and yaw), rotation alone a = G cos D, i.e. the scale (D only to
//   second order: b keeps its estimate and its variance grows). Not used:
//   epochs without a wheel twist or a mice estimate (a fallback to the
//   wheels), blocks with
//   d under min_speed times their length, and blocks whose innovation fails
//   the gated update's chi-square at gross_alpha (3 degrees of freedom; the
//   wheels slipped grossly). The measurement w of each
//   sensor's update (above) is predicted from the others' corrections, which
//   carry the applied common part (Gc, Dc) (see Applied), and is taken into
//   theta's gauge: times (Gc / G) R(D - Dc). The wheels' bias is the
//   gauge's: their systematic slip becomes the array's scale, hence not the
//   default (docs/self-calibration.md).
//
// Runaway, a hypothesis tested on the filter's own estimate: a sound sensor
// is within its tolerance of the configuration, |s - 1| <= runaway_scale on
// each axis and |delta| <= runaway_yaw (the bounds a user states for a
// sensor that is still the one configured). It is rejected when one
// component is beyond its bound by z standard deviations of its estimate,
// z = Phi^-1(1 - runaway_alpha) (a one-sided test at false-alarm rate
// runaway_alpha per component and update), and the sensor is reported by
// runaway() and left out of the estimate (Exclusion::kCalibration); it comes
// back when every component is inside its bound by z sd (the same test the
// other way: no hysteresis factor). It is still calibrated meanwhile. A
// calibration so far off that every block is rejected (a resolution 50 %
// off, a sensor turned by 30 degrees) is found by the reset above; then it
// runs away as above.
//
// Applied, a test: the configured value stands unless the estimate differs
// from it by more than z = Phi^-1(1 - apply_alpha / 2) standard deviations
// of its error (a two-sided test at false-alarm rate apply_alpha per
// component: a sensor as configured is corrected with that probability).
// The error's variance is P's plus a bias the three-parameter model cannot
// tell from a calibration: a mount position error e (sd
// mount_position_sigma) at r from the robot's origin reads, in rotation, as
// a scale e_r / r on the tangential axis and a yaw e_t / r. So with
// b = mount_position_sigma / r (r at least 1 cm) a component c is applied
// when |c - c_0| > z sqrt(P_cc + b^2), c_0 the configured 1 or 0. Its
// isotropic part g = sqrt(s_x s_y) (g - 1 ~ ((s_x - 1) + (s_y - 1)) / 2,
// variance (P_xx + P_yy + 2 P_xy) / 4 + b^2 / 4: the tangential axis is one
// of two, and a drift, dust, dims both alike) is applied to both axes when
// it alone passes; once an axis passes, both axes take their own estimates
// (a sensor plainly off) and its yaw with them: a translation in one
// direction pins two combinations of (s_x, s_y, delta), so scales applied
// without the yaw they were fitted with are off along the path. The test
// judges the relative calibration theta_i / (G, D); the gauge's common part
// is applied apart by the same test on the wheels' (a, b) (with kSensors it
// is (1, 0)). docs/self-calibration.md ("Applied") has the measurements.
//
// Fixed-size state, no allocation: runs in the heap-free core.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <optional>
#include <string_view>

#include "moa/core/array.hpp"
#include "moa/core/health.hpp"
#include "moa/core/names.hpp"
#include "moa/core/noise_model.hpp"
#include "moa/core/options_check.hpp"
#include "moa/core/robust_estimate.hpp"
#include "moa/core/subset.hpp"

namespace moa {

/// What fixes the common scale and yaw of all sensors (see above).
enum class SelfCalibrationGauge {
  kSensors,  ///< the sensors' median keeps the configured values
  kWheels,   ///< the wheels' twist, when the epochs have one
};
template <>
struct EnumNames<SelfCalibrationGauge> {
  static constexpr std::array<NameEntry<SelfCalibrationGauge>, 2> kTable{{
      {SelfCalibrationGauge::kSensors, "sensors"},
      {SelfCalibrationGauge::kWheels, "wheels"},
  }};
};

struct SelfCalibrationOptions {
  bool enabled = false;
  SelfCalibrationGauge gauge = SelfCalibrationGauge::kSensors;
  real block = 0.1;       ///< s of epochs summed per update
  real min_speed = 0.05;  ///< m/s, mean predicted point speed of a block
  /// 1/sqrt(s), random walk of a scale (forgetting): the variance of s grows
  /// by scale_walk^2 per second (docs/self-calibration.md says how it was chosen).
  real scale_walk = 0.01;
  real yaw_walk = 0.0003;       ///< rad/sqrt(s), random walk of the yaw offset
  real prior_scale_sd = 0.05;   ///< sd of the initial scale; the covariance cap
  real prior_yaw_sd = 0.02;     ///< rad, sd of the initial yaw offset; the cap
  real relative_noise = 0.003;  ///< sd of a block's displacement, fraction of it
  /// False-alarm rate (two-sided, per component) of the test that applies
  /// an estimate: a sensor as configured has its correction applied with
  /// this probability (header, "Applied").
  real apply_alpha = 0.001;
  /// m, sd of a sensor's mount position error, which the filter does not
  /// model: read in rotation as a scale and a yaw (header, "Applied").
  real mount_position_sigma = 0.0003;
  /// False-alarm rate of the test that calls a block gross (not used): its
  /// innovation's chi-square against the filter's prediction.
  real gross_alpha = 0.001;
  /// An epoch is not used for sensor i when the other sensors' fit fails
  /// the chi-square test at this level (they disagree among themselves).
  real predictor_alpha = 0.001;
  real runaway_scale = 0.25;  ///< tolerance of |s - 1| of a sound sensor (runaway test)
  real runaway_yaw = 0.2;     ///< rad, tolerance of |delta| of a sound sensor
  /// False-alarm rate per component and update of the runaway test (z sd).
  real runaway_alpha = 0.001;
  /// s, mean time between false resets of one sensor's calibration by the
  /// rejections' CUSUM (header, "Reset").
  real reset_false_alarm_time = 3600.0;
  /// The rejection rate the CUSUM is to detect (the alternative hypothesis):
  /// a calibration that fails half the blocks' tests is not this one.
  real reset_rate = 0.5;
  /// sd of the wide prior a reset restarts theta's covariance from: a
  /// calibration unknown within the range where the model still linearises
  /// (a resolution 50 % off, a sensor turned by 30 degrees).
  real reset_scale_sd = 0.5;
  real reset_yaw_sd = 0.5;  ///< rad
  /// A corrected sensor whose estimate moves faster than the filter's model
  /// of a steady calibration lets it (its random walk, scale_walk and
  /// yaw_walk) is held out of the estimate as drift while it moves
  /// (held_as_drift): a partial correction would let a sensor still off pass
  /// as consistent. The test: each scale against its own exponential
  /// average over settle_time s, the difference over its sd under that
  /// model, two-sided at hold_alpha; released below half the threshold.
  real settle_time = 1.0;
  /// False-alarm rate (two-sided, per scale and block) of the hold
  /// above. Higher than the accusing tests' 0.001: a false hold costs a
  /// sensor's share of the average for about settle_time, a missed one
  /// lets a partly corrected sensor bias the estimate.
  real hold_alpha = 0.05;
  real apply_step = 5e-4;  ///< change of an estimate that renews the applied correction
  /// A block in which a sensor's counts repeat exactly (not zero) this many
  /// epochs in a row is dropped: what a frozen register reads before the
  /// motion changes and the estimator's test can tell (health.hpp). A guard
  /// of the learning, not a fault test: a good sensor in a steady cruise
  /// repeats too (runs of up to 22 epochs at counts >= 4 on simulator seeds
  /// 1-30), and dropping such a block only slows its learning. Chosen on
  /// seeds 1-100.
  int repeat_run = 10;
  /// kWheels: 1/sqrt(s), random walk of the common scale (of a and b, above).
  real gauge_walk = 0.001;
  /// kWheels: sd of a block's wheel displacement, fraction of it (the
  /// simulator's noisy wheels: random slip 0.05 per wheel, correlated over
  /// 0.3 s).
  real wheel_noise = 0.05;
  /// nullopt when usable, else the first field out of its bounds, its path
  /// relative to this struct (options_check.hpp).
  OptionCheck validate() const;
};

/// One sensor's calibration relative to its configured mount.
struct SelfCalibrationEstimate {
  real scale_x = 1.0, scale_y = 1.0;  ///< 1: as configured
  real yaw_offset = 0.0;              ///< rad
};

class SelfCalibration {
 public:
  /// `noise`: the estimator's noise model: its min_squal marks the epochs
  /// not learnt from, its speed factor weighs the blocks near the rating.
  SelfCalibration(const SensorArray& array, SelfCalibrationOptions options,
                  const NoiseModelOptions& noise = {});

  /// Applies each sensor's correction to the counts of `sample` (in place).
  /// The applied correction changes only when an estimate moved by
  /// apply_step, so counts repeated by a frozen register stay identical.
  void correct(ArraySample& sample) const;

  /// Updates from one epoch: `raw` the uncorrected counts, `estimate` the
  /// estimator's output on the corrected counts, `wheels` the wheels' twist
  /// averaged over the epoch when there is one (used by the kWheels gauge),
  /// `repeats` the estimator's count of repeated readings (this epoch
  /// counted).
  void observe(const ArraySample& raw, const RobustEstimate& estimate,
               const std::optional<Twist2>& wheels, const RepeatCounter& repeats);

  /// The filter's estimate (theta) of sensor i.
  const SelfCalibrationEstimate& calibration(int i) const {
    return state_[static_cast<std::size_t>(i)].theta;
  }
  /// What is applied to sensor i's counts: the estimate where it passes
  /// the test that applies it (header, "Applied"), else as configured (1, 1, 0).
  const SelfCalibrationEstimate& applied(int i) const {
    return state_[static_cast<std::size_t>(i)].applied;
  }
  /// Standard deviations of (scale_x, scale_y, yaw_offset).
  Vec3 sd(int i) const;
  /// Blocks used for sensor i so far.
  long updates(int i) const { return state_[static_cast<std::size_t>(i)].updates; }
  /// Times sensor i's covariance was reset (the rejections' CUSUM alarmed
  /// and the blocks agreed with one calibration).
  long resets(int i) const { return state_[static_cast<std::size_t>(i)].resets; }
  /// The estimate ran away: the sensor is left out (kCalibration).
  bool runaway(int i) const { return state_[static_cast<std::size_t>(i)].runaway; }
  SensorMask runaways() const;
  /// Sensor i is held out (Exclusion::kDrift) while its own correction
  /// (beyond the gauge's common part) is applied and its estimate moves
  /// faster than a steady calibration's would (settle_time, hold_alpha; an
  /// estimate not applied is not held). Not latched: once the estimate
  /// settles the sensor is a candidate again, judged by the estimator's
  /// tests on its corrected counts like every other (a drift alarm of the
  /// health monitor holds it until its release test passes).
  bool held_as_drift(int i) const;
  int size() const { return n_; }
  /// The common part (G, G, D) the gauge sets the median over the sensors
  /// of the filter's isotropic scale and yaw offset to: (1, 1, 0) with
  /// kSensors, and with kWheels until the wheels told something.
  SelfCalibrationEstimate gauge() const;
  /// kWheels: blocks of wheel twists used so far.
  long gauge_updates() const { return wheel_.updates; }

 private:
  /// The blocks since the rejections' CUSUM left zero, summed for reset()'s
  /// least-squares fits (weights 1 / var).
  struct RejectionRun {
    Mat2 ww = Mat2::Zero(), mw = Mat2::Zero();  ///< sum w w^T / v, sum m w^T / v
    real mm = 0.0, wx = 0.0;                    ///< sum |m|^2 / v, sum (w x m) / v
    int blocks = 0;
    void add(const Vec2& w, const Vec2& m, real var);
  };
  struct SensorState {
    SelfCalibrationEstimate theta;
    SelfCalibrationEstimate renewed;         ///< theta when the correction was last renewed
    SelfCalibrationEstimate renewed_common;  ///< applied_gauge() then
    SelfCalibrationEstimate applied;  ///< theta through the test that applies it: in the correction
    Mat3 p = Mat3::Zero();
    Vec2 sum_meas{0.0, 0.0}, sum_pred{0.0, 0.0};  ///< m, configured sensor frame
    real sum_var = 0.0;                           ///< m^2, prediction variance
    real factor = 1.0;                            ///< the block's largest speed factor
    void clear_block() {
      sum_pred.setZero();
      sum_meas.setZero();
      sum_var = 0.0;
      factor = 1.0;
      time = 0.0;
    }
    real time = 0.0;            ///< s in the block
    double last_update = -1.0;  ///< s; < 0: never
    long updates = 0;
    bool runaway = false;
    long resets = 0;                     ///< covariance resets by reset()
    Vec3 moved = Vec3::Zero();           ///< theta less its average over settle_time (own steps)
    Vec3 moved_var = Vec3::Zero();       ///< moved's variance under the filter's model
    bool settling = false;               ///< theta is moving away from lagged
    bool corrected = false;              ///< its own correction (beyond the gauge's) is applied
    real rejections = 0.0;               ///< the rejections' CUSUM (log-likelihood ratio)
    RejectionRun run;                    ///< the blocks while it is above zero
    Mat2 correction = Mat2::Identity();  ///< counts -> corrected counts
  };
  /// kWheels: the array's twist against the wheels', summed over a block.
  struct WheelGauge {
    Vec2 k{1.0, 0.0};  ///< (a, b): a + i b = G e^(-iD)
    Mat2 p = Mat2::Zero();
    Vec2 sum_v_array{0.0, 0.0}, sum_v_wheels{0.0, 0.0};  ///< m, robot frame
    real sum_theta_array = 0.0, sum_theta_wheels = 0.0;  ///< rad
    real sum_var = 0.0;                                  ///< m^2, the array twist's
    real factor = 1.0;                                   ///< the block's largest speed factor
    real time = 0.0;                                     ///< s in the block
    double last_update = -1.0;                           ///< s; < 0: never
    long updates = 0;
  };
  void update(int i, double t);
  /// True when the run's blocks agree with one calibration: theta's
  /// covariance is then reset to the wide prior.
  bool reset(SensorState& s);
  void fix_gauge();
  void renew(int i);
  void observe_wheels(const ArraySample& raw, SensorMask used, const Twist2& wheels);
  void update_gauge(double t);
  /// gauge() through the same test (on the wheels' P): what the
  /// corrections apply of it.
  SelfCalibrationEstimate applied_gauge() const;

  SelfCalibrationOptions options_;
  NoiseModelOptions noise_;  ///< the estimators' (min_squal, speed_factor)
  int n_;
  SensorArray array_;
  SubsetSolver solver_;
  std::array<Mat2, kMaxSensors> velocity_from_counts_ = zeros<Mat2>();
  std::array<real, kMaxSensors> metres_per_count_{};
  std::array<real, 2 * kMaxSensors> chi2_gate_{};  ///< by degrees of freedom
  real runaway_z_ = 0.0;                           ///< Phi^-1(1 - runaway_alpha), sd
  real apply_z_ = 0.0;                             ///< Phi^-1(1 - apply_alpha / 2), sd
  real hold_z_ = 0.0;                              ///< Phi^-1(1 - hold_alpha / 2), sd
  std::array<real, kMaxSensors> mount_bias_{};     ///< mount_position_sigma / r_i
  real block_gate_ = 0.0;                          ///< q(1 - gross_alpha, 2): a sensor's block
  real wheel_gate_ = 0.0;  ///< q(1 - gross_alpha, 3): a block of the wheels' gauge
  real llr_rejected_ = 0.0, llr_fused_ = 0.0;  ///< the rejections' CUSUM steps
  real reset_h_ = 0.0;                         ///< its threshold
  std::array<SensorState, kMaxSensors> state_{};
  PointMeasurements points_;
  WheelGauge wheel_;
  real radius_ = 0.0;  ///< m, rms distance of the sensors from the robot origin
};

}  // namespace moa
