// The per-sensor noise model of the robust estimators: the covariance of
// each sensor's point velocity, inflated near the rated speed, on low SQUAL
// and on counter overflow.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>

#include "moa/core/array.hpp"
#include "moa/core/options_check.hpp"
#include "moa/core/robust_estimate.hpp"
#include "moa/core/subset.hpp"

namespace moa {

struct NoiseModelOptions {
  /// Std. dev. of a point velocity as a fraction of its speed: a mouse's
  /// resolution varies by a few percent with the surface and the height.
  real relative = 0.02;
  /// Variance multiplier m = min(speed_cap, 1 + (s / (onset * max_speed))^8)
  /// for the predicted point speed s: a sensor near or over its rating weighs
  /// less than one well under it. The cap matters: over its rating a sensor
  /// fails by losing counts (a gross error, not a wider Gaussian), which the
  /// consistency test must still see (docs/experiments.md, sekimori-table4,
  /// gives the measurements behind the cap).
  real speed_onset = 0.8;
  real speed_cap = 2.0;
  /// SQUAL below this inflates the variance by low_squal_factor.
  int min_squal = 16;
  real low_squal_factor = 100.0;
  /// Counter overflow inflates the variance by this (the counts are clipped).
  real overflow_factor = 1e4;
  /// nullopt when usable, else the first field out of its bounds, its path
  /// relative to this struct (options_check.hpp).
  OptionCheck validate() const;
  /// m's speed term for a point speed s (m/s) of a sensor rated at max_speed
  /// (m/s; 0 or less: not rated, 1): min(speed_cap, 1 + (s / (onset max_speed))^8).
  real speed_factor(real speed, real max_speed) const;
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
  /// Sensor i's information about the twist, A_i^T W^-1 A_i, from the
  /// quantisation of its counts alone: W = C_i C_i^T / 6 (m^2), the two end
  /// residuals of a sum of counts, whatever its length.
  Mat3 quantisation_information(int i) const;

 private:
  int n_;
  NoiseModelOptions options_;
  std::array<Mat2, kMaxSensors> c_ = zeros<Mat2>();      ///< m per count, robot frame
  std::array<Mat2, kMaxSensors> quant_ = zeros<Mat2>();  ///< C C^T / 6
  std::array<Mat<2, 3>, kMaxSensors> a_ = zeros<Mat<2, 3>>();
  std::array<real, kMaxSensors> noise2_{};
  std::array<real, kMaxSensors> max_speed_{};  ///< 0 when not rated
};

}  // namespace moa
