// Weighted least squares over any subset of the sensors, per sample,
// without allocation: the per-sensor blocks A_i^T and A_i^T A_i are kept,
// a subset's normal matrix is summed from them and inverted (3x3).
//
// For sensor point velocities u_i with covariances S_i (2x2, robot frame):
//   N = sum_i A_i^T S_i^-1 A_i,   x = N^-1 sum_i A_i^T S_i^-1 u_i,   Cov(x) = N^-1,
//   chi2 = sum_i (u_i - A_i x)^T S_i^-1 (u_i - A_i x)  with 2k - 3 degrees of
//   freedom for k sensors (the whitened residual of the fit).
#pragma once

#include <Eigen/Core>
#include <array>
#include <optional>

#include "moa/core/array.hpp"
#include "moa/core/se2.hpp"

namespace moa {

/// Sensor point velocities and their covariances for one sample.
struct PointMeasurements {
  int size = 0;
  std::array<Vec2, kMaxSensors> u = zeros<Vec2>();     ///< m/s, robot frame
  std::array<Mat2, kMaxSensors> info = zeros<Mat2>();  ///< S_i^-1, (s/m)^2
};

struct SubsetFit {
  Twist2 twist;
  Mat3 covariance = Mat3::Zero();
  real chi2 = 0.0;  ///< whitened residual
  int dof = 0;      ///< 2k - 3
};

class SubsetSolver {
 public:
  explicit SubsetSolver(const SensorArray& array);

  /// The fit of the sensors in `mask`; nullopt when they do not determine a
  /// twist (fewer than two, or rank deficient).
  std::optional<SubsetFit> fit(SensorMask mask, const PointMeasurements& m) const;

  /// A_i (2x3) of sensor i.
  const Mat<2, 3>& jacobian(int i) const { return a_[static_cast<std::size_t>(i)]; }
  int size() const { return n_; }

 private:
  int n_ = 0;
  std::array<Mat<2, 3>, kMaxSensors> a_ = zeros<Mat<2, 3>>();
};

}  // namespace moa
