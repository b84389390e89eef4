#include "moa/analysis/sensitivity.hpp"

#include <Eigen/LU>

namespace moa {
namespace {

/// sum_i A_i^T A_i and sum_i A_i^T w_i for points p_i (+ dp_i).
Eigen::Vector3d ls_twist(const SensorArray& array, const PointVectors& dp, const PointVectors& w) {
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  for (int i = 0; i < array.size(); ++i) {
    const auto s = static_cast<std::size_t>(i);
    SensorMount m = array[i];
    m.position += dp[s];
    const Eigen::Matrix<double, 2, 3> a = m.point_jacobian();
    normal += a.transpose() * a;
    rhs += a.transpose() * w[s];
  }
  return normal.inverse() * rhs;
}

}  // namespace

SensitivityTerms first_order_sensitivity(const SensorArray& nominal, const PointVectors& dp,
                                         const PointVectors& v_s, const PointVectors& dv_s) {
  Eigen::Matrix3d p = Eigen::Matrix3d::Zero(), dp_mat = Eigen::Matrix3d::Zero();
  Eigen::Vector3d at_vs = Eigen::Vector3d::Zero(), dat_vs = Eigen::Vector3d::Zero(),
                  at_dvs = Eigen::Vector3d::Zero();
  for (int i = 0; i < nominal.size(); ++i) {
    const auto s = static_cast<std::size_t>(i);
    const Eigen::Matrix<double, 2, 3> a = nominal[i].point_jacobian();
    Eigen::Matrix<double, 2, 3> da = Eigen::Matrix<double, 2, 3>::Zero();  // eq. (34)
    da(0, 2) = -dp[s].y();
    da(1, 2) = dp[s].x();
    p += a.transpose() * a;                             // (24)
    dp_mat += da.transpose() * a + a.transpose() * da;  // (25)
    at_vs += a.transpose() * v_s[s];
    dat_vs += da.transpose() * v_s[s];
    at_dvs += a.transpose() * dv_s[s];
  }
  const Eigen::Matrix3d p_inv = p.inverse();
  const Eigen::Vector3d v_m = p_inv * at_vs;
  SensitivityTerms t;
  t.dv1 = p_inv * dat_vs;
  t.dv2 = -p_inv * dp_mat * v_m;
  t.dv3 = p_inv * at_dvs;
  return t;
}

Eigen::Vector3d exact_sensitivity(const SensorArray& nominal, const PointVectors& dp,
                                  const PointVectors& v_s, const PointVectors& dv_s) {
  const PointVectors zero = zeros<Eigen::Vector2d>();
  PointVectors perturbed = zero;
  for (int i = 0; i < nominal.size(); ++i) {
    const auto s = static_cast<std::size_t>(i);
    perturbed[s] = v_s[s] + dv_s[s];
  }
  return ls_twist(nominal, dp, perturbed) - ls_twist(nominal, zero, v_s);
}

}  // namespace moa
