// Reusable checkers for the tests: numerical Jacobians, random mounts.
#pragma once

#include <Eigen/Core>
#include <random>

#include "moa/core/sensor.hpp"

namespace moa::test {

/// Central-difference Jacobian of f: R^n -> R^m at x, step h.
template <int M, int N, class F>
Eigen::Matrix<double, M, N> numerical_jacobian(F&& f, const Eigen::Matrix<double, N, 1>& x,
                                               double h = 1e-6) {
  Eigen::Matrix<double, M, N> j;
  for (int k = 0; k < N; ++k) {
    Eigen::Matrix<double, N, 1> a = x, b = x;
    a(k) += h;
    b(k) -= h;
    j.col(k) = (f(a) - f(b)) / (2.0 * h);
  }
  return j;
}

/// A random mount: position within 0.2 m, any yaw, scale 0.9..1.1, cpi
/// 400..1600, mirrored half the time.
inline SensorMount random_mount(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> pos(-0.2, 0.2), yaw(-3.14, 3.14), scale(0.9, 1.1),
      cpi(400.0, 1600.0);
  SensorMount m;
  m.position = {pos(rng), pos(rng)};
  m.yaw = yaw(rng);
  m.scale = {scale(rng), scale(rng)};
  m.cpi = cpi(rng);
  m.mirrored = (rng() & 1u) != 0;
  return m;
}

inline Twist2 random_twist(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> v(-0.5, 0.5), w(-2.0, 2.0);
  return {{v(rng), v(rng)}, w(rng)};
}

}  // namespace moa::test
