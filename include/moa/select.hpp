// What the robust estimators share: the per-sensor noise model, and the
// per-sample output saying which sensors were used, and why the others not.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <optional>

#include "moa/array.hpp"
#include "moa/estimate.hpp"
#include "moa/subset.hpp"

namespace moa {

/// Where a sample's twist came from.
enum class Source : std::uint8_t {
  kMice,    ///< a set of mouse sensors
  kWheels,  ///< wheel odometry (too few sensors could be trusted)
  kHold,    ///< the last good twist, covariance grown (no sensor, no wheels)
};
const char* describe(Source source);

/// Why a sensor was not used in a sample.
enum class Exclusion : std::uint8_t {
  kNone,          ///< used
  kLift,          ///< the sensor reported lift (flags bit 1)
  kInconsistent,  ///< not in the largest subset consistent with one rigid twist
  kUnreliable,    ///< Sekimori & Miyazaki eq. (7): reliability r_i below r_th
  kFallback,      ///< no set of two or more sensors could be trusted
};
const char* describe(Exclusion exclusion);

/// Conditions that inflated a sensor's noise in a sample (bit set).
enum NoiseFlag : std::uint8_t {
  kNoiseOverSpeed = 1u << 0,  ///< predicted speed near or over the rated max_speed
  kNoiseLowSqual = 1u << 1,   ///< SQUAL below the threshold
  kNoiseOverflow = 1u << 2,   ///< counter overflow reported
};

struct RobustEstimate {
  TwistEstimate estimate;  ///< twist, covariance, used sensors
  Source source = Source::kMice;
  std::array<Exclusion, kMaxSensors> excluded{};
  std::array<std::uint8_t, kMaxSensors> noise_flags{};
};

struct NoiseModelOptions {
  /// Std. dev. of a point velocity as a fraction of its speed: a mouse's
  /// resolution varies by a few percent with the surface and the height.
  double relative = 0.02;
  /// Variance multiplier m = min(speed_cap, 1 + (s / (onset * max_speed))^8)
  /// for the predicted point speed s: a sensor near or over its rating weighs
  /// less than one well under it. The cap matters: over its rating a sensor
  /// fails by losing counts (a gross error, not a wider Gaussian), which the
  /// consistency test must still see. Uncapped (~90 at 1.4 times the rating)
  /// the test let lost sensors in: `moa experiment sekimori-table4 --runs 5`,
  /// speed (b), consensus 151.9 mm uncapped, 26.7 mm with a cap of 4, 23.1 mm
  /// with 2, oracle selection 21.3 mm.
  double speed_onset = 0.8;
  double speed_cap = 2.0;
  /// SQUAL below this inflates the variance by low_squal_factor.
  int min_squal = 16;
  double low_squal_factor = 100.0;
  /// Counter overflow inflates the variance by this (the counts are clipped).
  double overflow_factor = 1e4;
};

/// Per-sensor covariance of the point velocity u_i (robot frame, m^2/s^2):
///   S_i = m_i (noise_i^2 I + C_i C_i^T / (6 dt^2) + (relative * s_i)^2 I)
/// with C_i metres per count, s_i = min(|u_i measured|, |u_i predicted|) (a
/// sensor cannot widen its own tolerance by reporting a wild speed), and
/// m_i the product of the inflation factors that apply.
class NoiseModel {
 public:
  NoiseModel(const SensorArray& array, NoiseModelOptions options = {});

  /// Fills u and info (S_i^-1) for all sensors and returns their noise flags.
  void measure(const ArraySample& sample, const Twist2& predicted, PointMeasurements& out,
               std::array<std::uint8_t, kMaxSensors>& flags) const;
  const NoiseModelOptions& options() const { return options_; }

 private:
  int n_;
  NoiseModelOptions options_;
  std::array<Eigen::Matrix2d, kMaxSensors> c_ =
      zeros<Eigen::Matrix2d>();  ///< m per count, robot frame
  std::array<Eigen::Matrix2d, kMaxSensors> quant_ = zeros<Eigen::Matrix2d>();  ///< C C^T / 6
  std::array<Eigen::Matrix<double, 2, 3>, kMaxSensors> a_ = zeros<Eigen::Matrix<double, 2, 3>>();
  std::array<double, kMaxSensors> noise2_{};
  std::array<double, kMaxSensors> max_speed_{};  ///< 0 when not rated
};

/// Covariance of a wheel-odometry twist: wheels slip, more when fast.
///   sd(v) = base_v + rel * |v|,  sd(omega) = base_omega + rel * |omega|.
struct WheelNoise {
  double base_v = 0.02;      ///< m/s
  double base_omega = 0.05;  ///< rad/s
  double relative = 0.1;
  Eigen::Matrix3d covariance(const Twist2& wheels) const;
};

/// The twist to use when nothing can be trusted and there are no wheels:
/// the last good one, its covariance grown by a random walk in acceleration
/// (accel m/s^2, angular accel rad/s^2) over the time since it was good.
struct HoldModel {
  double accel = 1.0;
  double angular_accel = 5.0;
  Eigen::Matrix3d grown(const Eigen::Matrix3d& covariance, double elapsed) const;
};

/// What both robust estimators do when no set of sensors can be trusted:
/// the wheel twist (its covariance from WheelNoise), or without wheels the
/// last good twist held with its covariance grown (HoldModel).
class Fallback {
 public:
  /// Records a twist that came from the mice at time t.
  void good(const Twist2& twist, const Eigen::Matrix3d& covariance, double t) {
    last_twist_ = twist;
    last_covariance_ = covariance;
    last_good_t_ = t;
  }
  /// Fills out's twist, covariance and source for a sample at time t.
  void apply(RobustEstimate& out, const std::optional<Twist2>& wheels,
             const WheelNoise& wheel_noise, const HoldModel& hold, double t);
  /// The best guess of the current twist (for predicting sensor speeds).
  const Twist2& last_twist() const { return last_twist_; }

 private:
  Twist2 last_twist_;
  Eigen::Matrix3d last_covariance_ = Eigen::Matrix3d::Zero();
  double last_good_t_ = 0.0;
};

}  // namespace moa
