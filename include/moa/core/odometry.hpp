// The odometry pipeline: every front end (moa odometry, moa live, the
// experiments, the benchmarks, the Python bindings, the Cortex-M4F program)
// runs this one type.
//
//   mice rows ──> Synchroniser ──> ArraySample (one epoch, period 1/rate)
//   wheel rows ─> WheelAverager ──┐      │
//                                 v      v
//                  twist estimator (ls | sekimori | consensus | wheels | oracle)
//                                        │ RobustEstimate: twist, covariance,
//                                        │ source, used/excluded + reasons
//                                        v
//                  DeadReckoner, or PoseEkf with camera fixes (fuse_camera)
//                                        │
//                                        v
//                  OdometryStep (pose, twist, covariances, selection) -> sink
//
// Inputs are fed in time order of their own time stamps: mice rows by t,
// wheel rows by t, camera fixes by capture time (the CSV readers' order; a
// front end merging several streams feeds the earliest first). An epoch
// (t - dt, t] is processed once the synchroniser has made it final and, when
// wheels are used, once a wheel row at or after t has been fed (or finish()
// is called), so the wheel twist averaged over the epoch is complete. A
// camera fix captured at t_c is applied at the first epoch ending at or after
// its stamp t (captured at t - camera_latency, PoseEkf handles late fixes).
// Every stream is shifted by its latency (a row's t minus the true time of
// what it reports): the mice per sensor in the synchroniser
// (SensorMount::latency), the wheels, the gyro and the fixes here.
//
// Heap-free: fixed-size state and rings (kMaxSensors, kMaxPendingEpochs,
// PoseEkf::kHistory); the sink is a non-owning callable reference.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cstdint>
#include <optional>
#include <string_view>
#include <type_traits>
#include <utility>
#include <variant>

#include "moa/core/array.hpp"
#include "moa/core/consensus.hpp"
#include "moa/core/dead_reckoner.hpp"
#include "moa/core/ekf.hpp"
#include "moa/core/estimate.hpp"
#include "moa/core/fallback.hpp"
#include "moa/core/names.hpp"
#include "moa/core/noise_model.hpp"
#include "moa/core/ring.hpp"
#include "moa/core/robust_estimate.hpp"
#include "moa/core/se2.hpp"
#include "moa/core/sekimori.hpp"
#include "moa/core/self_calibration.hpp"
#include "moa/core/subset.hpp"
#include "moa/core/synchronise.hpp"
#include "moa/core/wheels.hpp"

namespace moa {

/// The twist estimators the pipeline can run.
enum class EstimatorKind : std::uint8_t {
  kLs,         ///< weighted least squares over all selected sensors (Kim & Lee eq. (7))
  kSekimori,   ///< pairwise voting (Sekimori & Miyazaki eqs. (4), (7)-(9)), wheels as fallback
  kConsensus,  ///< largest chi-square-consistent subset, wheels as fallback and check
  kWheels,     ///< wheel odometry alone (the mice are not used)
  kOracle,     ///< least squares over the sensors with no simulated fault in the epoch,
               ///< with the gyro as configured where it had none
};
template <>
struct EnumNames<EstimatorKind> {
  static constexpr std::array<NameEntry<EstimatorKind>, 5> kTable{{
      {EstimatorKind::kLs, "ls"},
      {EstimatorKind::kSekimori, "sekimori"},
      {EstimatorKind::kConsensus, "consensus"},
      {EstimatorKind::kWheels, "wheels"},
      {EstimatorKind::kOracle, "oracle"},
  }};
};

struct OdometryOptions {
  EstimatorKind estimator = EstimatorKind::kConsensus;
  /// The sensors the estimator may use (bit i: sensor i); the others are
  /// reported as excluded, reason "unselected".
  SensorMask sensors = ~SensorMask{0};
  double rate = 100.0;  ///< Hz, epochs (1 / SynchroniserOptions::period)
  /// s, longest interval one mice row covers; callers that leave it to the
  /// user default it to default_max_row_interval(rate)
  double max_row_interval = 0.05;
  double max_gap = 3600.0;  ///< s, longest silence of all sensors
  bool use_wheels = true;   ///< wheel rows fed are used (fallback, plausibility)
  /// gyro rows fed are used (consensus: consensus.gyro is the gyro's model)
  bool use_imu = true;
  /// world_T_robot at the first epoch's start. Unset: identity, or with
  /// fuse_camera the first fix fed before the first epoch is processed.
  std::optional<Pose2> initial;
  bool fuse_camera = false;  ///< EKF with camera fixes
  /// s, a fix's t minus its true capture time (the camera's stamp is its
  /// arrival, or another clock's): the fix is taken as captured at
  /// t - camera_latency and applied once the epochs reach t. nullopt: the
  /// config's `camera: {latency}`, else 0 (io::make_odometry resolves it).
  std::optional<double> camera_latency;
  /// s, a wheel row's t minus the true end of its interval (the config's
  /// `wheels: {latency}`).
  double wheels_latency = 0.0;
  real camera_sigma = 0.005;         ///< m, fix sd when the fix gives none
  real camera_heading_sigma = 0.02;  ///< rad, sd of a fix's heading
  SekimoriOptions sekimori;
  ConsensusOptions consensus;
  EkfOptions ekf;
  /// Online self-calibration of the selected sensors (self_calibration.hpp):
  /// off unless self_calibration.enabled; states of the consensus estimator
  /// (refused with ls, sekimori and oracle; with wheels nothing is learnt).
  SelfCalibrationOptions self_calibration;

  /// nullopt when the options can be used, else the first field out of its
  /// bounds with its full path, the bound and the value
  /// ("consensus.health.drift_shift: must be > 0, is 0"), in the manner of
  /// Ceres' Options::IsValid (options_check.hpp). Every nested struct
  /// included.
  OptionCheck validate() const;
  /// 0.05 s, or 60 epochs where that is shorter (a row may span at most
  /// kMaxPendingEpochs - 3 = 61 periods: at 5000 Hz 0.05 s would be 250).
  static double default_max_row_interval(double rate) {
    return std::min<double>(0.05, 60.0 / rate);
  }
  SynchroniserOptions synchroniser() const { return {1.0 / rate, max_row_interval, max_gap}; }
};

/// A camera fix: position (world frame, m), optionally heading (rad), with
/// standard deviations (m) when the camera gives them.
struct CameraFix {
  double t = 0.0;  ///< s, capture time
  Vec2 position{0.0, 0.0};
  std::optional<real> theta;
  std::optional<Vec2> sigma;
};

/// Counts of what happened to the camera fixes.
struct FixCounts {
  std::size_t applied = 0, rejected = 0, too_old = 0, invalid = 0;
};

/// One output epoch.
struct OdometryStep {
  /// The epoch's counts (speed scales undone); valid during the sink call.
  const ArraySample* sample = nullptr;
  RobustEstimate estimate;              ///< twist (robot frame), covariance, selection
  Pose2 pose;                           ///< world_T_robot at sample->t
  bool fused = false;                   ///< pose_covariance is the EKF's
  Mat3 pose_covariance = Mat3::Zero();  ///< (x, y, theta), with fuse_camera
  bool scaled = false;  ///< with fuse_camera and ekf.estimate_scale: scale is estimated
  /// The EKF's dead-reckoning scales (s_v, s_w) (PoseEkf::scale()); (1, 1) unless scaled.
  Vec2 scale{1.0, 1.0};
  Mat2 scale_covariance = Mat2::Zero();  ///< of (s_v, s_w)
  /// With self_calibration.enabled, by configured index (1, 1, 0 for a
  /// sensor not selected), else null: the calibration applied to each
  /// sensor's counts (SelfCalibration::applied), and the filter's estimate
  /// behind it (SelfCalibration::calibration; equal where it is applied).
  const std::array<SelfCalibrationEstimate, kMaxSensors>* calibration = nullptr;
  const std::array<SelfCalibrationEstimate, kMaxSensors>* calibration_filter = nullptr;
  /// With self_calibration.enabled, by configured index: the filter's
  /// standard deviations of (scale_x, scale_y, yaw_offset rad)
  /// (SelfCalibration::sd), else null.
  const std::array<Vec3, kMaxSensors>* calibration_sd = nullptr;
  /// With self_calibration.enabled, by configured index: how many times
  /// each sensor's calibration was reset so far (SelfCalibration::resets:
  /// its blocks failed the gate at more than the false-alarm rate and agreed
  /// with another calibration), else null.
  const std::array<long, kMaxSensors>* calibration_resets = nullptr;
  /// With the consensus estimator and a gyro stream (use_imu, gyro rows
  /// fed), the gyro's model after this epoch (its calibration: bias() rad/s,
  /// scale(), covariance()), else null; valid during the sink call.
  const GyroModel* gyro = nullptr;
  double t() const { return sample->t; }
};

enum class OdometryError : std::uint8_t {
  kRow,                ///< the mice row is invalid (row_error says why)
  kNoInterval,         ///< an epoch with no positive, finite interval
  kWheelsFull,         ///< wheel rows fed too far ahead of the mice rows
  kFixesFull,          ///< camera fixes fed too far ahead of the mice rows
  kWheelsBackwards,    ///< a wheel row earlier than the previous one, or not finite
  kImuFull,            ///< gyro rows fed too far ahead of the mice rows
  kImuBackwards,       ///< a gyro row earlier than the previous one, or not finite
  kImpossibleCounts,   ///< counts implying a speed far beyond what the sensor can track
  kImplausibleWheels,  ///< a wheel twist beyond core/plausible.hpp's bounds, or not finite
  kImplausibleGyro,    ///< a gyro rate beyond core/plausible.hpp's bound, or not finite
  kImplausibleFix,     ///< a camera fix beyond core/plausible.hpp's bounds, or not finite
};

const char* describe(OdometryError error);

/// A non-owning reference to a callable, as std::function without the heap:
/// the referenced callable must outlive the call it is passed to.
template <class Signature>
class FunctionRef;
template <class R, class... Args>
class FunctionRef<R(Args...)> {
 public:
  template <class F>
  requires(!std::is_same_v<std::remove_cvref_t<F>, FunctionRef>) FunctionRef(
      F&& f)  // NOLINT(google-explicit-constructor): a reference, like std::function_ref
      : object_(const_cast<void*>(static_cast<const void*>(&f))),
        call_([](void* object, Args... args) -> R {
          return (*static_cast<std::remove_reference_t<F>*>(object))(std::forward<Args>(args)...);
        }) {}
  R operator()(Args... args) const { return call_(object_, std::forward<Args>(args)...); }

 private:
  void* object_;
  R (*call_)(void*, Args...);
};

using StepSink = FunctionRef<void(const OdometryStep&)>;

class Odometry {
 public:
  /// Camera fixes that may wait for their epoch.
  static constexpr std::size_t kMaxPendingFixes = 32;

  /// Final epochs that may wait for the wheel row that covers them.
  static constexpr std::size_t kMaxWaitingEpochs = 16;

  /// Builds the pipeline for `array` with validated options (`validate()`
  /// empty), the first epoch starting at t0 (s). Built in place (the object
  /// is large: rings of epochs and the EKF's history), so check
  /// geometry_error() before use: a geometry the estimator cannot use.
  Odometry(const SensorArray& array, double t0, const OdometryOptions& options);
  std::optional<GeometryError> geometry_error() const { return geometry_error_; }

  /// A mice row; calls sink for every epoch that became ready.
  std::optional<OdometryError> push(const SensorRow& row, StepSink sink);
  /// A wheel-odometry row: twist (robot frame) averaged over the interval
  /// since the previous wheel row, ending at t. Ignored unless use_wheels.
  std::optional<OdometryError> push_wheels(double t, const Twist2& twist, StepSink sink);
  /// A gyro row (imu.csv): the rate about z (rad/s, counter-clockwise)
  /// averaged over the interval since the previous gyro row, ending at t as
  /// stamped (the pipeline takes t - consensus.gyro.latency). Used by the
  /// consensus estimator and the oracle (which leaves out the epochs that
  /// overlap a `faulty` row: the simulator's truth, imu.csv's `faults`);
  /// ignored unless use_imu.
  std::optional<OdometryError> push_gyro(double t, double gz, StepSink sink, bool faulty = false);
  /// A camera fix (ignored unless fuse_camera).
  std::optional<OdometryError> push_fix(const CameraFix& fix);
  /// Ends the stream at t_end (the last row's time): emits every remaining
  /// epoch, the last one cut at t_end.
  void finish(double t_end, StepSink sink);

  /// The row error of the last kRow error.
  RowError row_error() const { return row_error_; }
  const Synchroniser& synchroniser() const { return sync_; }
  std::size_t steps() const { return steps_; }
  const FixCounts& fixes() const { return fixes_; }
  const OdometryOptions& options() const { return options_; }
  const Pose2& pose() const;

 private:
  /// The estimator, built for the selected sensors only (sub_array_).
  using Estimator = std::variant<std::monostate, LsEstimator, SekimoriEstimator, ConsensusEstimator,
                                 SubsetSolver>;
  void on_epoch(const ArraySample& sample, StepSink sink);
  void drain(bool all, StepSink sink);
  void process(const ArraySample& raw, StepSink sink);
  /// The epoch with each sensor's counts divided by its speed scale's ratio
  /// (corrected_counts, core/sensor.hpp); `raw` itself when no sensor has one.
  const ArraySample& undo_speed_scale(const ArraySample& raw);
  /// Into `out`, default-constructed; false when the epoch has no interval.
  bool estimate(const ArraySample& sample, const std::optional<Twist2>& wheels,
                const std::optional<real>& gyro, RobustEstimate& out);
  void fuse_oracle_gyro(real g, real dt, RobustEstimate& e) const;
  /// Every stream an epoch waits for has a row at or after t.
  bool covered(double t) const;
  void apply_fixes(double t);
  Mat2 fix_covariance(const CameraFix& fix) const;

  OdometryOptions options_;
  int n_;                                    ///< sensors in the configured array
  int m_;                                    ///< selected sensors
  std::array<int, kMaxSensors> selected_{};  ///< index in the array of selected sensor k
  SensorArray sub_array_;
  Estimator estimator_;
  NoiseModel noise_;   ///< oracle's noise model
  Fallback fallback_;  ///< for the wheels and oracle estimators
  PointMeasurements points_;
  ArraySample compact_;               ///< the selected sensors' counts of the current epoch
  RobustEstimate selected_estimate_;  ///< its estimate, in the selection's indices
  Synchroniser sync_;
  WheelAverager wheels_;
  bool wheels_seen_ = false;
  double last_wheel_t_ = 0.0;
  /// rad/s, on the mice's clock (latency removed); the oracle's faulty rows NaN
  IntervalAverager<1> gyro_;
  bool gyro_seen_ = false;
  double last_gyro_t_ = 0.0;
  FixedRing<ArraySample, kMaxWaitingEpochs> ready_;  ///< final epochs waiting for wheels
  FixedRing<CameraFix, kMaxPendingFixes> pending_fixes_;
  DeadReckoner reckoner_;
  std::optional<PoseEkf> ekf_;
  bool started_ = false;
  double t0_;
  double period_;  ///< s, 1 / rate
  FixCounts fixes_;
  std::size_t steps_ = 0;
  RowError row_error_ = RowError::kTimeNotFinite;
  std::optional<OdometryError> deferred_error_;
  std::optional<GeometryError> geometry_error_;
  /// Per configured sensor: m/s per count (G_i^-1), the speed refused.
  std::array<Mat2, kMaxSensors> velocity_from_counts_ = zeros<Mat2>();
  std::array<real, kMaxSensors> impossible_speed_{};
  std::array<SpeedScale, kMaxSensors> speed_scales_{};
  bool speed_scaled_ = false;  ///< some sensor has a speed scale
  ArraySample scaled_;         ///< the current epoch, its speed scales undone
  std::array<SelfCalibrationEstimate, kMaxSensors>
      calibration_{};  ///< applied, by configured index
  std::array<SelfCalibrationEstimate, kMaxSensors> calibration_filter_{};  ///< the filter's
  std::array<Vec3, kMaxSensors> calibration_sd_ = zeros<Vec3>();           ///< its sds
  std::array<long, kMaxSensors> calibration_resets_{};  ///< SelfCalibration::resets
};

}  // namespace moa
