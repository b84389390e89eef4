#include "moa_bench/baselines.hpp"

#include <Eigen/Dense>
#include <vector>

namespace moa::baseline {

namespace {
Eigen::Vector2d point_velocity(const SensorArray& array, const ArraySample& sample, int i) {
  return array[i].robot_velocity_from_counts() * sample.counts[static_cast<std::size_t>(i)] /
         sample.dt;
}
}  // namespace

Twist2 naive_ls(const SensorArray& array, const ArraySample& sample) {
  const int n = array.size();
  Eigen::MatrixXd a(2 * n, 3);
  Eigen::VectorXd u(2 * n);
  for (int i = 0; i < n; ++i) {
    a.middleRows<2>(2 * i) = array[i].point_jacobian();
    u.segment<2>(2 * i) = point_velocity(array, sample, i);
  }
  const Eigen::MatrixXd pinv = a.completeOrthogonalDecomposition().pseudoInverse();
  const Eigen::VectorXd x = pinv * u;
  return Twist2::from_vector(Eigen::Vector3d(x(0), x(1), x(2)));
}

Twist2 naive_sekimori(const SensorArray& array, const ArraySample& sample, double e_th, int r_th) {
  const int n = array.size();
  std::vector<int> votes(static_cast<std::size_t>(n), 0);
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      Eigen::MatrixXd a(4, 3);
      Eigen::VectorXd d(4);
      a.topRows(2) = array[i].point_jacobian();
      a.bottomRows(2) = array[j].point_jacobian();
      d << point_velocity(array, sample, i) * sample.dt,
          point_velocity(array, sample, j) * sample.dt;
      const Eigen::MatrixXd pinv = a.completeOrthogonalDecomposition().pseudoInverse();
      const double e = (a * (pinv * d) - d).squaredNorm();
      if (e <= e_th) {
        ++votes[static_cast<std::size_t>(i)];
        ++votes[static_cast<std::size_t>(j)];
      }
    }
  }
  std::vector<int> reliable;
  for (int i = 0; i < n; ++i) {
    if (votes[static_cast<std::size_t>(i)] >= r_th) reliable.push_back(i);
  }
  if (reliable.size() < 2) return {};
  const auto m = static_cast<Eigen::Index>(reliable.size());
  Eigen::MatrixXd b(2 * m, 3);
  Eigen::VectorXd v(2 * m);
  for (Eigen::Index k = 0; k < m; ++k) {
    const int i = reliable[static_cast<std::size_t>(k)];
    b.middleRows<2>(2 * k) = array[i].point_jacobian();
    v.segment<2>(2 * k) = point_velocity(array, sample, i);
  }
  const Eigen::VectorXd x = b.completeOrthogonalDecomposition().pseudoInverse() * v;
  return Twist2::from_vector(Eigen::Vector3d(x(0), x(1), x(2)));
}

}  // namespace moa::baseline
