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
  std::array<Eigen::Vector2d, kMaxSensors> u = zeros<Eigen::Vector2d>();     ///< m/s, robot frame
  std::array<Eigen::Matrix2d, kMaxSensors> info = zeros<Eigen::Matrix2d>();  ///< S_i^-1, (s/m)^2
};

struct SubsetFit {
  Twist2 twist;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  double chi2 = 0.0;  ///< whitened residual
  int dof = 0;        ///< 2k - 3
};

class SubsetSolver {
 public:
  explicit SubsetSolver(const SensorArray& array);

  /// The fit of the sensors in `mask`; nullopt when they do not determine a
  /// twist (fewer than two, or rank deficient).
  std::optional<SubsetFit> fit(SensorMask mask, const PointMeasurements& m) const;

  /// A_i (2x3) of sensor i.
  const Eigen::Matrix<double, 2, 3>& jacobian(int i) const {
    return a_[static_cast<std::size_t>(i)];
  }
  int size() const { return n_; }

 private:
  int n_ = 0;
  std::array<Eigen::Matrix<double, 2, 3>, kMaxSensors> a_ = zeros<Eigen::Matrix<double, 2, 3>>();
};

}  // namespace moa
