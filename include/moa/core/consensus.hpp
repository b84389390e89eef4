// The consensus estimator: the largest set of sensors that one rigid-body
// twist explains, by a chi-square test on the whitened residual.
//
// Per sample:
//  1. Point velocities u_i and covariances S_i from the NoiseModel (at the
//     sample's dt, inflated near the rated speed, on low SQUAL or overflow),
//     predicted with the last twist. Sensors that report lift are out.
//  2. For k = candidates down to 2, every subset of k sensors is fitted
//     (SubsetSolver) and passes when chi2 <= q(1 - alpha, 2k - 3). When
//     minority (a subset of at most half the sensors) could agree by chance
//     while the majority is lost, so it needs corroboration by each
//     reference there is, judged with the reference's covariance alone:
//       wheels  (x - x_w)^T W^-1 (x - x_w) <= q(1 - alpha, 3),
//       prior   (x - x_p)^T P^-1 (x - x_p) <= q(1 - alpha, 3),
//     x_p, P the motion prior (motion_prior.hpp: the last trusted twist, its
//     covariance grown by the robot's acceleration limits). Not with the
//     subset's covariance Cov added: two sensors that under-read alike fit
//     each other well, and their wide Cov would let them pass.
//     Among the passing subsets of the largest k the smallest
//     chi2 + sum over the references of (x - x_r)^T (Cov + R)^-1 (x - x_r)
//     wins (the joint likelihood ranks subsets of one size).
//  Before step 2 the health monitor (health.hpp) takes out the sensors it
//  has excluded over time (frozen, zero, drift, probation); after it, the
//  estimate feeds its drift test.
//  3. The common-mode hypothesis: the whole array wrong at once (every
//     sensor loses the floor over a bump and reads zero; four sensors that
//     agree pass every test among themselves). A majority subset's twist x
//     with covariance Cov is rejected when every reference contradicts it,
//       (x - x_r)^T (Cov + R)^-1 (x - x_r) > q(1 - alpha, 3)  for r in
//       {prior, wheels present},
//     so at the false-alarm rate of one test while the references are
//     honest. Then the epoch is bridged as in step 4 (wheels, or hold),
//     every candidate reported `common-mode`. The hypothesis is tested anew
//     each epoch, never latched: the array is taken back as soon as one
//     reference accepts its twist, and in any case once it has been bridged
//     for `max_bridge` s (the references could be the ones that
//     are wrong: spinning wheels against a wall).
//  4. Nothing passes: the wheel twist (source wheels) or, without wheels,
//     the last good twist with its covariance grown (source hold).
// With a gyro (gyro.hpp) its calibrated rate omega_g is one more source, on
// the rotation only, tested against the array's:
//   (omega_a - omega_g)^2 / (Cov_ww + var_g) > q(1 - alpha, 1).
// Either can be the one that is wrong (a stuck gyro, an array that lost the
// floor while turning): the gyro against the array. At the onset of an
// episode of disagreement the other references decide: the array is blamed
// when the wheels reject its twist or the prior its rotation,
//   (omega_a - omega_p)^2 / (Cov_ww + P_ww) > q(1 - alpha, 1),
// the prior fresh from the epoch before; else the gyro is. The blame holds
// until the two agree again (the prior, not renewed over a bridge, soon
// accepts anything), the array's for at most max_bridge s: an array wrong
// for longer than a lost floor lasts is more likely right, and the gyro is
// blamed from then on. An array blamed is common-mode wrong (step 3); a gyro
// blamed is not used (`gyro_rejected`): the rotation is the array's, the
// gyro learns nothing and its heading's error is forgotten.
// Over time: a gyro stuck within the array's noise (on a fast robot a
// compact array's rotation is noisy: a stuck reading passes each epoch's
// test and turns the heading for seconds) shows as a disagreement of one
// sign epoch after epoch. Its normalised value z = (omega_a - omega_g) /
// sqrt(C_ww + var_g), clipped at the gate, feeds two one-sided CUSUMs
// (cusum.hpp, reference 0.5 sd, one false alarm an hour at the epoch
// rate); each is capped at twice its alarm level, so a gyro that recovers
// is back within about 4 h epochs. An alarm, unless the wheels reject the
// array's twist, blames the gyro until both statistics are back at zero.
// Not fed while the array is blamed (its readings are then the fault).
// Otherwise, whenever the gyro reads (not saturated) the rotation reported is
// the gyro's, with the heading's error its calibration leaves taken back as
// the array teaches it (gyro.hpp): an accepted array twist teaches the
// gyro's bias and scale and gives the translation; a bridge (step 3, 4)
// takes its translation from the wheels or the hold.
// The prior is the twist of step 2, or of the wheels in step 3; a hold does
// not renew it (its covariance keeps growing). With motion_prior off the
// estimator is the one before the prior: no prior, and the wheel test of a
// minority uses Cov + W.
// Self-calibration (self_calibration.hpp, when enabled): its states (each
// sensor's scale on both axes and yaw offset, the wheels' gauge) belong to
// this estimator. The counts are corrected by them before step 1; a sensor
// whose calibration ran away, or whose correction is held out as drift
// while it moves, is a hypothesis of its own: left out of the search
// (`calibration`, `drift`) but still tested against the epoch's twist
// (tests.sensor), back once its estimate settles (no latch); after the
// epoch the states learn from the uncorrected counts and the repeat
// counter the health monitor names `frozen` by (no lift flag, no label
// carries them).
// Subsets of each size are enumerated in increasing bit order as they are
// needed (N <= 10, so at most 1013 fits and no table to store); for larger
// arrays the worst sensor is dropped greedily. Per-sample cost does not
// depend on the log's length and nothing is allocated, not even at
// construction (the estimator runs on microcontrollers without a heap).
#pragma once

#include <cstdint>
#include <optional>

#include "moa/core/cusum.hpp"
#include "moa/core/fallback.hpp"
#include "moa/core/gyro.hpp"
#include "moa/core/health.hpp"
#include "moa/core/motion_prior.hpp"
#include "moa/core/noise_model.hpp"
#include "moa/core/options_check.hpp"
#include "moa/core/self_calibration.hpp"

namespace moa {

struct ConsensusOptions {
  real alpha = 1e-3;  ///< false-rejection rate of the chi-square tests
  NoiseModelOptions noise;
  WheelNoise wheels;
  HoldModel hold;
  /// Test candidates against the motion prior and judge a minority with the
  /// references' covariances alone (step 2 above).
  bool motion_prior = true;
  RobotLimits limits;
  /// Faults over time (health.hpp): frozen, zero and drifting sensors are
  /// kept out of the search.
  HealthOptions health;
  /// The common-mode test of step 3 (needs motion_prior).
  bool common_mode = true;
  real max_bridge = 1.0;  ///< s, longest bridge over a common-mode rejection
  /// The gyro, when a gyro stream is fed (config `imu:`).
  GyroOptions gyro;
  /// A gyro stream will be fed: then one sensor suffices (one_sensor below).
  bool gyro_fed = false;
  /// nullopt when usable, else the first field out of its bounds, its path
  /// relative to this struct (options_check.hpp).
  OptionCheck validate() const;
};

class ConsensusEstimator {
 public:
  static constexpr int kMaxExhaustive = 10;

  /// Refuses arrays that no two sensors can observe (see LsEstimator::create).
  /// `calibration`: the online self-calibration, built when enabled.
  static std::variant<ConsensusEstimator, GeometryError> create(
      const SensorArray& array, ConsensusOptions options = {},
      const SelfCalibrationOptions& calibration = {});

  /// One sample; `wheels` is the wheel twist over the same interval, if any,
  /// `gyro` the gyro's reading averaged over it (rad/s, before calibration).
  /// Returns nullopt only when dt is not positive and finite.
  std::optional<RobustEstimate> estimate(const ArraySample& sample,
                                         const std::optional<Twist2>& wheels = std::nullopt,
                                         const std::optional<real>& gyro = std::nullopt);
  const GyroModel& gyro() const { return gyro_; }
  /// The self-calibration's states, null unless it was enabled.
  const SelfCalibration* self_calibration() const {
    return calibration_ ? &*calibration_ : nullptr;
  }

 private:
  ConsensusEstimator(const SensorArray& array, ConsensusOptions options,
                     const SelfCalibrationOptions& calibration);
  /// The estimate from counts the self-calibration corrected (or raw, without
  /// one); `held` the sensors its hypotheses leave out.
  /// The interval is checked by estimate().
  RobustEstimate estimate_counts(const ArraySample& sample, SensorMask held,
                                 const std::optional<Twist2>& wheels,
                                 const std::optional<real>& gyro);
  struct Candidate {
    SubsetFit fit;
    SensorMask mask = 0;
    real cost = 0.0;
  };
  /// A twist a candidate is checked against: the wheels or the prior.
  struct Reference {
    Vec3 x = Vec3::Zero();
    Mat3 covariance = Mat3::Zero();
    Mat3 information = Mat3::Zero();  ///< covariance^-1, once `informed`
  };
  struct References {
    std::array<Reference, 2> r;
    int size = 0;
    int wheels = -1;  ///< index of the wheels' reference, -1 without wheels
    /// The informations are computed: only minority subsets need them.
    bool informed = false;
  };
  std::optional<Candidate> search(SensorMask candidates, References& refs) const;
  /// `alone`: no other subset of mask's size competes, so its cost (the
  /// ranking among them) is not computed.
  bool consider(SensorMask mask, References& refs, bool alone,
                std::optional<Candidate>& best) const;
  /// The candidate's twist against each reference: tests.wheels, tests.prior.
  void test_references(const Candidate& best, const References& refs, SourceTests& tests) const;
  /// The gyro against the array (above): updates the episode's blame.
  void blame(const Candidate& best, const References& refs, const SourceTests& tests, double t);
  /// The gyro against the array over time (above): z the epoch's
  /// normalised disagreement; sets gyro_drifting_.
  void drift_test(real z, real dt, const SourceTests& tests);
  /// Step 3: every reference rejects the majority candidate's twist.
  bool common_mode(const Candidate& best, const References& refs, const SourceTests& tests,
                   double t) const;
  /// The gyro's rotation `omega` (GyroModel::drive) as out's, with the
  /// rate's variance.
  void take_gyro_rotation(const GyroRate& rate, real omega, RobustEstimate& out) const;
  /// An accepted epoch into the gyro's calibration window (gyro.hpp).
  /// `still`: the robot at rest (the wheels read nothing, the array agrees).
  void teach_gyro(real g, const ArraySample& sample, const RobustEstimate& out, bool still);
  /// One sensor and a gyro (an OTOS-class robot): the sensor measures its
  /// point's velocity u = v + omega (z x r), two numbers for three; the
  /// gyro's rate gives omega, so v = u - omega (z x r), with covariance
  /// S + (z x r)(z x r)^T var_g. Nothing checks the sensor against another:
  /// its translation is tested against the wheels and the motion prior
  /// (2 dof, at alpha), and when every one there is rejects it (a lost
  /// floor, within max_bridge) the epoch is bridged as in step 3. The gyro
  /// learns its bias at rest only (the wheels read nothing), its scale not
  /// at all: no rotation is measured but its own.
  /// Sensor i alone (the array's only one, or the only one the health
  /// monitor left among `candidates`, which it goes on testing).
  RobustEstimate one_sensor(int i, SensorMask candidates, const ArraySample& sample,
                            const References& refs, const std::optional<Twist2>& wheels,
                            const std::optional<real>& gyro, const std::optional<GyroRate>& rate,
                            RobustEstimate out);
  /// Each sensor's residual against the epoch's twist x: tests.sensor.
  void test_sensors(const Twist2& x, SourceTests& tests) const;

  int n_;
  ConsensusOptions options_;
  SubsetSolver solver_;
  NoiseModel noise_;
  std::array<real, 2 * kMaxSensors> threshold_{};  ///< by dof
  real wheel_threshold_ = 0.0;
  real gyro_threshold_ = 0.0;  ///< q(1 - alpha, 1)
  // State carried between samples.
  PointMeasurements measurements_;
  Fallback fallback_;
  MotionPrior prior_;
  HealthMonitor health_;
  GyroModel gyro_;
  /// The sensors of the gyro's calibration window and the angle variance of
  /// their counts' quantisation (rad^2, once per window).
  SensorMask gyro_mask_ = 0;
  real gyro_q_ = 0;
  /// s, the last epoch whose twist came from the mice (none yet: nullopt)
  std::optional<double> last_mice_t_;
  /// An episode of disagreement between the gyro and the array: which of the
  /// two is blamed, decided at its onset and kept until they agree again.
  enum class Blame : std::uint8_t { kNone, kArray, kGyro };
  Blame blame_ = Blame::kNone;
  double blame_since_ = 0.0;  ///< s, the episode's first epoch
  /// The gyro against the array over time: CUSUMs of the normalised
  /// disagreement (a stuck gyro within the array's noise, epoch after
  /// epoch), their alarm level (sd; 0 until the first epoch), and the
  /// hypothesis they raised: the gyro drifting, until both are back at 0.
  static constexpr real kDriftShift = real(0.5);
  static constexpr real kDriftFalseAlarmTime = real(3600);
  TwoSidedCusum gyro_drift_;
  real gyro_drift_h_ = 0;
  bool gyro_drifting_ = false;
  RepeatCounter repeats_;  ///< of the counts as read (health: frozen; self-calibration's guard)
  std::optional<SelfCalibration> calibration_;
  ArraySample corrected_;  ///< the epoch's counts through calibration_'s correction
};

}  // namespace moa
