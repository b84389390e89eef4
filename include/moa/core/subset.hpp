// Weighted least squares over any subset of the sensors, per sample,
// without allocation: the per-sensor blocks A_i^T and A_i^T A_i are kept,
// a subset's normal matrix is summed from them and inverted (3x3).
//
// For sensor point velocities u_i with covariances S_i (2x2, robot frame):
//   N = sum_i A_i^T S_i^-1 A_i,   x = N^-1 sum_i A_i^T S_i^-1 u_i,   Cov(x) = N^-1,
//   chi2 = sum_i (u_i - A_i x)^T S_i^-1 (u_i - A_i x)  with 2k - 3 degrees of
//   freedom for k sensors (the whitened residual of the fit).
// The terms A_i^T S_i^-1 A_i and A_i^T S_i^-1 u_i do not depend on the
// subset: an estimator that fits several subsets of one sample computes
// them once (prepare) and each fit sums them, in the same order and with
// the same operations as a fit that computes them itself (bit-identical).
#pragma once

#include <Eigen/Core>
#include <array>
#include <optional>

#include "moa/core/array.hpp"
#include "moa/core/se2.hpp"

namespace moa {

class SubsetSolver;

/// Sensor point velocities and their covariances for one sample.
struct PointMeasurements {
  int size = 0;
  std::array<Vec2, kMaxSensors> u = zeros<Vec2>();     ///< m/s, robot frame
  std::array<Mat2, kMaxSensors> info = zeros<Mat2>();  ///< S_i^-1, (s/m)^2
  /// Per-sensor terms of the normal equations, A_i^T S_i^-1 A_i (units of
  /// Cov(x)^-1) and A_i^T S_i^-1 u_i (of Cov(x)^-1 x), valid for the solver
  /// `prepared_by` points to; whoever changes u or info sets it back to
  /// nullptr (NoiseModel::measure does).
  std::array<Mat3, kMaxSensors> normal = zeros<Mat3>();
  std::array<Vec3, kMaxSensors> rhs = zeros<Vec3>();
  const SubsetSolver* prepared_by = nullptr;
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
  /// twist (fewer than two, or rank deficient). Sums m's prepared terms when
  /// this solver prepared them, else computes them.
  std::optional<SubsetFit> fit(SensorMask mask, const PointMeasurements& m) const;
  /// fit()'s twist alone, bit for bit (the same sums and solve), without
  /// the residual's chi-square or the covariance: for a caller that reads
  /// only the twist (the health monitor's leave-one-out twists).
  std::optional<Twist2> twist(SensorMask mask, const PointMeasurements& m) const;
  /// Computes m.normal and m.rhs of every sensor from m.u and m.info, for
  /// this solver's A_i.
  void prepare(PointMeasurements& m) const;

  /// A_i (2x3) of sensor i.
  const Mat<2, 3>& jacobian(int i) const { return a_[static_cast<std::size_t>(i)]; }
  int size() const { return n_; }

 private:
  /// The normal equations of `mask` solved: false when they do not
  /// determine a twist; else `inv` their inverse and `x` the twist.
  bool solve(SensorMask mask, const PointMeasurements& m, Mat3& inv, Vec3& x) const;

  int n_ = 0;
  std::array<Mat<2, 3>, kMaxSensors> a_ = zeros<Mat<2, 3>>();
};

}  // namespace moa
