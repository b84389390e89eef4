#include <gtest/gtest.h>

#include <random>

#include "moa/analysis/sensitivity.hpp"
#include "support/checks.hpp"

namespace moa {
namespace {

struct Case {
  SensorArray array;
  PointVectors dp = zeros<Eigen::Vector2d>(), v_s = dp, dv_s = dp;
};

Case random_case(std::mt19937_64& rng, double scale) {
  std::normal_distribution<double> g(0.0, 1.0);
  Case c;
  c.array = regular_polygon(4, 0.2, 0.3);
  const Twist2 x = test::random_twist(rng);
  for (int i = 0; i < 4; ++i) {
    const auto s = static_cast<std::size_t>(i);
    c.dp[s] = scale * Eigen::Vector2d(g(rng), g(rng)) * 0.01;
    c.v_s[s] = c.array[i].point_jacobian() * x.vector() + 0.01 * Eigen::Vector2d(g(rng), g(rng));
    c.dv_s[s] = scale * Eigen::Vector2d(g(rng), g(rng)) * 0.01;
  }
  return c;
}

TEST(Sensitivity, FirstOrderErrorShrinksQuadratically) {
  // The neglected terms (22), (27), (28) are products of two deviations: the
  // gap to the exact change must fall by ~4 when every deviation halves.
  for (std::uint64_t seed = 40; seed < 50; ++seed) {
    double previous = 0.0;
    for (double scale : {0.2, 0.1, 0.05}) {
      std::mt19937_64 rng(seed);
      const Case c = random_case(rng, scale);
      const Eigen::Vector3d first = first_order_sensitivity(c.array, c.dp, c.v_s, c.dv_s).total();
      const Eigen::Vector3d exact = exact_sensitivity(c.array, c.dp, c.v_s, c.dv_s);
      const double gap = (first - exact).norm();
      ASSERT_GT(exact.norm(), 0.0);
      if (previous > 0.0) {
        EXPECT_NEAR(previous / gap, 4.0, 0.6) << "seed " << seed;
      }
      previous = gap;
    }
  }
}

TEST(Sensitivity, CorrectGeometryAndItsMeasurementsCancel) {
  // Measurements that the deviated mice really make (dv_s = dA v_m) are
  // explained by the deviated geometry: the first-order change vanishes.
  const SensorArray a = regular_polygon(3, 0.3, -0.5);
  const Twist2 x{{0.2, 0.1}, 1.0 / 3.0};
  PointVectors dp = zeros<Eigen::Vector2d>(), v_s = dp, dv_s = dp;
  for (int i = 0; i < 3; ++i) {
    const auto s = static_cast<std::size_t>(i);
    dp[s] = Eigen::Vector2d(0.004 * (i + 1), -0.003 * i);
    v_s[s] = a[i].point_jacobian() * x.vector();
    dv_s[s] = x.omega * Eigen::Vector2d(-dp[s].y(), dp[s].x());
  }
  EXPECT_LT(first_order_sensitivity(a, dp, v_s, dv_s).total().norm(), 1e-15);
  EXPECT_LT(exact_sensitivity(a, dp, v_s, dv_s).norm(), 1e-15);
}

}  // namespace
}  // namespace moa
