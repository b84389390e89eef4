#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "moa/core/array.hpp"
#include "moa/core/sensor.hpp"
#include "support/checks.hpp"

namespace moa {
namespace {

TEST(Sensor, MeasurementModelFollowsSpecStepByStep) {
  std::mt19937_64 rng(2);
  for (int k = 0; k < 200; ++k) {
    const SensorMount m = test::random_mount(rng);
    const Twist2 x = test::random_twist(rng);
    const double dt = 0.01;
    // docs/formats/config.md, written out in scalars.
    const double ux = x.v.x() - x.omega * m.position.y();
    const double uy = x.v.y() + x.omega * m.position.x();
    double wx = std::cos(m.yaw) * ux + std::sin(m.yaw) * uy;
    double wy = -std::sin(m.yaw) * ux + std::cos(m.yaw) * uy;
    if (m.mirrored) wy = -wy;
    const double k_cpm = m.cpi / 0.0254;
    const Eigen::Vector2d expected(k_cpm * m.scale.x() * wx * dt, k_cpm * m.scale.y() * wy * dt);
    EXPECT_TRUE(m.counts(x, dt).isApprox(expected, 1e-12));
  }
}

TEST(Sensor, CountsToVelocityInvertsVelocityToCounts) {
  std::mt19937_64 rng(3);
  for (int k = 0; k < 50; ++k) {
    const SensorMount m = test::random_mount(rng);
    EXPECT_TRUE((m.robot_velocity_from_counts() * m.counts_from_robot_velocity())
                    .isApprox(Eigen::Matrix2d::Identity(), 1e-12));
  }
}

TEST(Sensor, ParameterJacobianMatchesFiniteDifferences) {
  std::mt19937_64 rng(4);
  std::vector<Twist2> twists{{{0.0, 0.0}, 0.0}, {{1e-9, 0.0}, 1e-9}, {{0.0, 0.0}, 1.0}};
  for (int k = 0; k < 20; ++k) twists.push_back(test::random_twist(rng));
  for (const Twist2& x : twists) {
    const SensorMount base = test::random_mount(rng);
    const auto f = [&](const Eigen::Matrix<double, 5, 1>& q) {
      SensorMount m = base;
      m.position = q.head<2>();
      m.yaw = q(2);
      m.scale = q.tail<2>();
      return Eigen::Vector2d(m.counts(x, 1.0));
    };
    Eigen::Matrix<double, 5, 1> q;
    q << base.position, base.yaw, base.scale;
    const Eigen::Matrix<double, 2, 5> numeric = test::numerical_jacobian<2, 5>(f, q);
    const Eigen::Matrix<double, 2, 5> analytic = base.parameter_jacobian(x);
    // Central differences on counts of size ~1e5: truncation ~h^2 f''' and
    // rounding ~1e-16 * 1e5 / 1e-6 = 1e-5 counts per unit parameter.
    EXPECT_LT((numeric - analytic).cwiseAbs().maxCoeff(), 1e-3 + 1e-8 * analytic.norm());
  }
}

TEST(Sensor, TwistJacobianIsKimLeeMatrixPerMouse) {
  // For a mouse aligned with the robot (yaw 0, scale 1), A_i = [1 0 -p_y; 0 1 p_x]
  // (Kim & Lee eq. (6)), so H_i = k A_i.
  SensorMount m;
  m.position = {0.3, -0.1};
  Eigen::Matrix<double, 2, 3> a;
  a << 1, 0, 0.1, 0, 1, 0.3;
  EXPECT_TRUE(m.point_jacobian().isApprox(a));
  EXPECT_TRUE(m.twist_jacobian().isApprox(m.counts_per_metre() * a));
}

TEST(Sensor, RegularPolygonFollowsKimLeeEq1AndSumsToZero) {
  for (int n = 2; n <= 8; ++n) {
    const double r = 0.3, theta = -std::numbers::pi / 6.0;
    const SensorArray a = regular_polygon(n, r, theta);
    ASSERT_EQ(a.size(), n);
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    for (int i = 0; i < n; ++i) {
      const double angle = theta + i * 2.0 * std::numbers::pi / n;
      EXPECT_NEAR(a[i].position.x(), r * std::cos(angle), 1e-15);
      EXPECT_NEAR(a[i].position.y(), r * std::sin(angle), 1e-15);
      EXPECT_EQ(a[i].yaw, 0.0);
      sum += a[i].position;
    }
    EXPECT_NEAR(sum.norm(), 0.0, 1e-15);  // Kim & Lee eq. (2)
  }
  // Kim & Lee eq. (51): nominal positions of their example.
  const SensorArray k = regular_polygon(3, 0.3, -std::numbers::pi / 6.0);
  EXPECT_NEAR(k[0].position.x(), 0.3 * 0.866, 1e-4);
  EXPECT_NEAR(k[1].position.y(), 0.3 * 1.000, 1e-12);
  EXPECT_NEAR(k[2].position.x(), -0.3 * 0.866, 1e-4);
}

TEST(Sensor, DownsamplerEmitsSumEveryKPackets) {
  Downsampler d(12);
  int emitted = 0;
  for (int j = 1; j <= 36; ++j) {
    const auto out = d.push(j, -1);
    if (j % 12 == 0) {
      ASSERT_TRUE(out.has_value());
      // sum of j over one block of 12: 12 * first + 66
      EXPECT_EQ(out->x(), 12 * (j - 11) + 66);
      EXPECT_EQ(out->y(), -12);
      ++emitted;
    } else {
      EXPECT_FALSE(out.has_value());
    }
  }
  EXPECT_EQ(emitted, 3);
}

TEST(Sensor, VelocityFromCountsIsKimLeeEq50) {
  // ADNS-3080 at 1600 cpi, 6400 fps, K = 12: 10 counts per packet is
  // 120 counts = 0.075 in in 12/6400 s = 40 in/s = 1.016 m/s (its rated max).
  EXPECT_NEAR(velocity_from_counts(120.0, 1600.0, 12, 6400.0), 1.016, 1e-12);
  EXPECT_NEAR(velocity_from_counts(120.0, 1600.0, 12, 6400.0), kAdns3080.max_speed, 1e-12);
}

TEST(Sensor, PresetsCarryDatasheetFigures) {
  EXPECT_EQ(kHdns2051.cpi, 800.0);
  EXPECT_NEAR(kHdns2051.max_speed, 0.3556, 1e-12);
  EXPECT_EQ(kHdns2051.frame_rate, 2300.0);
  EXPECT_EQ(kAdns3080.cpi, 1600.0);
  EXPECT_EQ(kAdns3080LowCpi, 400.0);
  EXPECT_NEAR(kAdns3080.max_speed, 1.016, 1e-12);
  EXPECT_EQ(kAdns3080MaxFrameRate, 6469.0);
}

TEST(SensorMount, ImpossibleCountsAreThoseBeyondTheLimitByTheNorm) {
  SensorMount rated;
  rated.max_speed = 1.5;
  EXPECT_DOUBLE_EQ(impossible_speed(rated), 10 * 1.5);
  EXPECT_DOUBLE_EQ(impossible_speed(SensorMount{}), 50.0);
  SensorMount m;
  m.yaw = 0.7;
  m.scale = Vec2(1.1, 0.9);
  const Mat2 g = m.robot_velocity_from_counts();
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double dt = 0.01, limit = 2.0;
  for (int k = 0; k < 2000; ++k) {
    // Counts around the limit: |g c| / (limit dt) in [0.5, 1.5], and a few exactly on it.
    Vec2 c(u(rng), u(rng));
    c *= limit * dt / (g * c).norm() * (k % 100 == 0 ? 1.0 : 1.0 + 0.5 * u(rng));
    EXPECT_EQ(counts_impossible(g, c, limit, dt), (g * c).norm() > limit * dt) << k;
  }
  EXPECT_TRUE(counts_impossible(g, Vec2(2e9, 0.0), limit, dt));
  EXPECT_FALSE(counts_impossible(g, Vec2::Zero(), limit, dt));
}

}  // namespace
}  // namespace moa
