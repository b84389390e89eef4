// The output of a robust estimator for one sample: the twist with its
// covariance, where it came from, and per sensor whether it was used and, if
// not, why; the noise-inflation flags of each sensor.
#pragma once

#include <array>
#include <cstdint>
#include <limits>

#include "moa/core/array.hpp"
#include "moa/core/estimate.hpp"
#include "moa/core/names.hpp"

namespace moa {

/// Where a sample's twist came from.
enum class Source : std::uint8_t {
  kMice,    ///< a set of mouse sensors
  kWheels,  ///< wheel odometry (too few sensors could be trusted)
  kHold,    ///< the last good twist, covariance grown (no sensor, no wheels)
};
/// The `source` column of odometry.csv.
template <>
struct EnumNames<Source> {
  static constexpr std::array<NameEntry<Source>, 3> kTable{{
      {Source::kMice, "mice"},
      {Source::kWheels, "wheels"},
      {Source::kHold, "hold"},
  }};
};

/// Why a sensor was not used in a sample.
enum class Exclusion : std::uint8_t {
  kNone,          ///< used
  kLift,          ///< the sensor reported lift (flags bit 1)
  kInconsistent,  ///< not in the largest subset consistent with one rigid twist
  kUnreliable,    ///< Sekimori & Miyazaki eq. (7): reliability r_i below r_th
  kFallback,      ///< no set of two or more sensors could be trusted
  kUnselected,    ///< not among the sensors the estimator was given (--sensors, wheels)
  kFaulty,        ///< oracle: the simulator reports a fault in the epoch
  kFrozen,        ///< health: the same non-zero counts epoch after epoch (health.hpp)
  kZero,          ///< health: zero counts while the array moves
  kDrift,         ///< health: its residual against the others drifts (scale or yaw)
  kProbation,     ///< health: was excluded; kept out until it behaves for a while
  kCalibration,   ///< self-calibration: its estimate ran away from 1 (self_calibration.hpp)
  kCommonMode,    ///< the whole array at once contradicts the motion prior and the wheels
};
/// The reasons of the `excluded` column of odometry.csv ("used": not excluded).
template <>
struct EnumNames<Exclusion> {
  static constexpr std::array<NameEntry<Exclusion>, 13> kTable{{
      {Exclusion::kNone, "used"},
      {Exclusion::kLift, "lift"},
      {Exclusion::kInconsistent, "inconsistent"},
      {Exclusion::kUnreliable, "unreliable"},
      {Exclusion::kFallback, "fallback"},
      {Exclusion::kUnselected, "unselected"},
      {Exclusion::kFaulty, "faulty"},
      {Exclusion::kFrozen, "frozen"},
      {Exclusion::kZero, "zero"},
      {Exclusion::kDrift, "drift"},
      {Exclusion::kProbation, "probation"},
      {Exclusion::kCalibration, "calibration"},
      {Exclusion::kCommonMode, "common-mode"},
  }};
};

/// Conditions that inflated a sensor's noise in a sample (bit set).
enum NoiseFlag : std::uint8_t {
  kNoiseOverSpeed = 1u << 0,  ///< predicted speed near or over the rated max_speed
  kNoiseLowSqual = 1u << 1,   ///< SQUAL below the threshold
  kNoiseOverflow = 1u << 2,   ///< counter overflow reported
  /// predicted speed over the rated max_speed itself (with kNoiseOverSpeed):
  /// where a sensor fails by losing counts, not by a wider Gaussian. Not
  /// written to odometry.csv (over-speed says it).
  kNoiseOverRating = 1u << 3,
};
/// An epoch's test ratios, in the manner of PX4 EKF2's aid-source status:
/// each source's test statistic divided by its gate, so 1 is the gate and a
/// source above it is inconsistent with the epoch's twist x. NaN where a
/// source was not tested (no such stream, an estimator without the tests).
struct SourceTests {
  /// Sensor i: r_i^T S_i^-1 r_i / q(1 - alpha, 2), r_i = u_i - A_i x its
  /// point velocity's residual (m/s), S_i its covariance (noise_model.hpp).
  std::array<real, kMaxSensors> sensor;
  /// The array's twist x_a (the subset the search chose, if any) against
  /// the wheels' and the motion prior's: d^T (Cov + R)^-1 d / q(1 - alpha, 3),
  /// d = x_a - x_r: the common-mode test (consensus.hpp, step 3).
  real wheels = std::numeric_limits<real>::quiet_NaN();
  real prior = std::numeric_limits<real>::quiet_NaN();
  /// The gyro's calibrated rate omega_g against the array's omega_a:
  /// (omega_a - omega_g)^2 / (Cov_ww + var_g) / q(1 - alpha, 1) (gyro.hpp).
  real gyro = std::numeric_limits<real>::quiet_NaN();
  bool gyro_fused = false;  ///< the gyro's rate went into the twist
  /// The gyro is the source blamed for its disagreement with the array
  /// (consensus.hpp, "the gyro against the array"): its rate is not used.
  bool gyro_rejected = false;
  bool gyro_saturated = false;  ///< its reading was at its full scale: not used
  SourceTests() { sensor.fill(std::numeric_limits<real>::quiet_NaN()); }
};

struct RobustEstimate {
  TwistEstimate estimate;  ///< twist, covariance, used sensors
  Source source = Source::kMice;
  std::array<Exclusion, kMaxSensors> excluded{};
  std::array<std::uint8_t, kMaxSensors> noise_flags{};
  SourceTests tests;  ///< the consensus's test ratios (NaN for the other estimators)
};

}  // namespace moa
