#include "moa/core/subset.hpp"

#include <Eigen/LU>

namespace moa {

SubsetSolver::SubsetSolver(const SensorArray& array) : n_(array.size()) {
  for (int i = 0; i < n_ && i < kMaxSensors; ++i)
    a_[static_cast<std::size_t>(i)] = array[i].point_jacobian();
}

void SubsetSolver::prepare(PointMeasurements& m) const {
  for (int i = 0; i < n_; ++i) {
    const auto s = static_cast<std::size_t>(i);
    const Mat<3, 2> at_info = a_[s].transpose() * m.info[s];
    m.normal[s].noalias() = at_info * a_[s];
    m.rhs[s].noalias() = at_info * m.u[s];
  }
  m.prepared_by = this;
}

bool SubsetSolver::solve(SensorMask mask, const PointMeasurements& m, Mat3& inv, Vec3& x) const {
  if (count_sensors(mask) < 2) return false;
  Mat3 normal = Mat3::Zero();
  Vec3 rhs = Vec3::Zero();
  if (m.prepared_by == this) {
    for (int i = 0; i < n_; ++i) {
      if (!contains(mask, i)) continue;
      const auto s = static_cast<std::size_t>(i);
      normal += m.normal[s];
      rhs += m.rhs[s];
    }
  } else {
    for (int i = 0; i < n_; ++i) {
      if (!contains(mask, i)) continue;
      const auto s = static_cast<std::size_t>(i);
      const Mat<3, 2> at_info = a_[s].transpose() * m.info[s];
      normal.noalias() += at_info * a_[s];
      rhs.noalias() += at_info * m.u[s];
    }
  }
  bool invertible = false;
  real det = 0.0;
  normal.computeInverseAndDetWithCheck(inv, det, invertible, 0.0);
  // Relative determinant test: det / (product of the diagonal) measures how
  // close the normal matrix is to singular, independent of the weights' scale.
  const real scale = normal(0, 0) * normal(1, 1) * normal(2, 2);
  if (!invertible || !(det > 1e-12 * scale)) return false;
  x = inv * rhs;
  return true;
}

std::optional<Twist2> SubsetSolver::twist(SensorMask mask, const PointMeasurements& m) const {
  Mat3 inv;
  Vec3 x;
  if (!solve(mask, m, inv, x)) return std::nullopt;
  return Twist2::from_vector(x);
}

std::optional<SubsetFit> SubsetSolver::fit(SensorMask mask, const PointMeasurements& m) const {
  Mat3 inv;
  Vec3 x;
  if (!solve(mask, m, inv, x)) return std::nullopt;
  const int k = count_sensors(mask);
  SubsetFit out;
  out.twist = Twist2::from_vector(x);
  out.covariance = inv;
  out.dof = 2 * k - 3;
  for (int i = 0; i < n_; ++i) {
    if (!contains(mask, i)) continue;
    const auto s = static_cast<std::size_t>(i);
    const Vec2 r = m.u[s] - a_[s] * x;
    out.chi2 += r.dot(m.info[s] * r);
  }
  return out;
}

}  // namespace moa
