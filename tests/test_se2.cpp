#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "moa/core/se2.hpp"
#include "support/checks.hpp"

namespace moa {
namespace {

constexpr double kPi = std::numbers::pi;

TEST(Se2, ComposeWithInverseIsIdentity) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> d(-5.0, 5.0);
  for (int k = 0; k < 100; ++k) {
    const Pose2 a{{d(rng), d(rng)}, d(rng)};
    const Pose2 i = a * a.inverse();
    EXPECT_NEAR(i.t.norm(), 0.0, 1e-12);
    EXPECT_NEAR(i.theta, 0.0, 1e-12);
  }
}

TEST(Se2, CompositionActsLikeMatrixProduct) {
  // Independent check with 3x3 homogeneous matrices.
  const auto h = [](const Pose2& p) {
    Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
    m(0, 0) = std::cos(p.theta), m(0, 1) = -std::sin(p.theta);
    m(1, 0) = std::sin(p.theta), m(1, 1) = std::cos(p.theta);
    m(0, 2) = p.t.x(), m(1, 2) = p.t.y();
    return m;
  };
  const Pose2 a{{1.0, -2.0}, 0.7}, b{{0.3, 0.4}, -2.1};
  EXPECT_TRUE(h(a * b).isApprox(h(a) * h(b), 1e-12));
  const Eigen::Vector2d p(0.5, -0.25);
  EXPECT_TRUE((a * p).isApprox((h(a) * p.homogeneous()).head<2>(), 1e-12));
}

TEST(Se2, WrapAngleLandsInHalfOpenInterval) {
  EXPECT_DOUBLE_EQ(wrap_angle(3.0 * kPi), kPi);
  EXPECT_DOUBLE_EQ(wrap_angle(-kPi), kPi);
  EXPECT_NEAR(wrap_angle(2.0 * kPi + 0.1), 0.1, 1e-12);
  EXPECT_NEAR(wrap_angle(-7.0), -7.0 + 2.0 * kPi, 1e-12);
}

TEST(Se2, ExactIntegrationOfConstantTwistClosesCircle) {
  // v = 0.5 m/s forward, one turn in T = 4 s: radius r = v / omega, centre (0, r).
  const double period = 4.0, v = 0.5, omega = 2.0 * kPi / period, r = v / omega;
  const Twist2 twist{{v, 0.0}, omega};
  for (int steps : {7, 100, 1000}) {
    Pose2 pose;
    const double dt = period / steps;
    for (int k = 0; k < steps; ++k) {
      pose = integrate_exact(pose, twist, dt);
      EXPECT_NEAR((pose.t - Eigen::Vector2d(0.0, r)).norm(), r, 1e-12);
    }
    EXPECT_NEAR(pose.t.norm(), 0.0, 1e-12) << steps << " steps";
    EXPECT_NEAR(pose.theta, 2.0 * kPi, 1e-12);
  }
}

TEST(Se2, EulerErrorShrinksLinearlyAndExactHasNone) {
  // Constant twist with lateral velocity; the closed form after time T is exp(xi T).
  const Twist2 twist{{0.4, -0.2}, 1.3};
  const double duration = 2.0;
  const Pose2 truth = exp(twist, duration);
  double previous = 0.0;
  for (int steps : {50, 100, 200, 400}) {
    Pose2 euler, exact;
    for (int k = 0; k < steps; ++k) {
      euler = integrate_euler(euler, twist, duration / steps);
      exact = integrate_exact(exact, twist, duration / steps);
    }
    const double error = (euler.t - truth.t).norm();
    EXPECT_NEAR((exact.t - truth.t).norm(), 0.0, 1e-12);
    if (previous > 0.0) {
      EXPECT_NEAR(previous / error, 2.0, 0.05) << steps;  // O(dt)
    }
    previous = error;
  }
}

TEST(Se2, SmallAngleBranchMatchesClosedFormAcrossThreshold) {
  // exp() switches to Taylor series below kSmallAngle; compare both sides
  // with the closed form in long double.
  for (double phi : {kSmallAngle * 0.999, kSmallAngle * 1.001, 1e-9, 0.0, -kSmallAngle * 0.5}) {
    const Twist2 twist{{1.0, 0.5}, phi};
    const Pose2 p = exp(twist, 1.0);
    long double s = 1.0L, c = 0.0L;
    if (phi != 0.0) {
      // 1 - cos(phi) = 2 sin^2(phi / 2): no cancellation near zero.
      const long double half = std::sin(static_cast<long double>(phi) / 2.0L);
      s = std::sin(static_cast<long double>(phi)) / phi;
      c = 2.0L * half * half / phi;
    }
    EXPECT_NEAR(p.t.x(), static_cast<double>(s * 1.0L - c * 0.5L), 1e-15) << phi;
    EXPECT_NEAR(p.t.y(), static_cast<double>(c * 1.0L + s * 0.5L), 1e-15) << phi;
  }
}

TEST(Se2, ExpMatchesFineIntegration) {
  // Many tiny Euler steps converge to the exponential.
  const Twist2 twist{{-0.3, 0.8}, -2.2};
  Pose2 fine;
  const int steps = 200000;
  for (int k = 0; k < steps; ++k) fine = integrate_euler(fine, twist, 1.0 / steps);
  const Pose2 e = exp(twist, 1.0);
  EXPECT_NEAR((fine.t - e.t).norm(), 0.0, 2e-5);  // O(dt) = O(5e-6)
  EXPECT_NEAR(fine.theta, e.theta, 1e-10);        // 2e5 rounded additions
}

TEST(Se2, TwistBetweenInvertsExp) {
  std::mt19937_64 rng(7);
  for (int i = 0; i < 200; ++i) {
    const Twist2 x = test::random_twist(rng);
    const double dt = 0.01 + 0.5 * std::uniform_real_distribution<double>(0, 1)(rng);
    const Pose2 from{{0.3 * i, -0.1 * i}, 0.05 * i};
    const Pose2 to = integrate_exact(from, x, dt);
    const Twist2 back = twist_between(from, to, dt);
    EXPECT_NEAR(back.v.x(), x.v.x(), 1e-9);
    EXPECT_NEAR(back.v.y(), x.v.y(), 1e-9);
    EXPECT_NEAR(back.omega, x.omega, 1e-9);
  }
  // Near zero rotation (the Taylor branch).
  const Twist2 slow{{0.2, -0.1}, 1e-7};
  const Twist2 back = twist_between({}, exp(slow, 0.5), 0.5);
  EXPECT_NEAR(back.v.x(), 0.2, 1e-12);
  EXPECT_NEAR(back.v.y(), -0.1, 1e-12);
  EXPECT_NEAR(back.omega, 1e-7, 1e-15);
}

Eigen::Vector3d vec(const Pose2& p) { return {p.t.x(), p.t.y(), p.theta}; }
Pose2 pose_of(const Eigen::Vector3d& x) { return {{x(0), x(1)}, x(2)}; }

TEST(Se2, ExpStepJacobiansMatchFiniteDifferencesAtIdentityNearZeroAndRandom) {
  std::mt19937_64 rng(50);
  std::vector<std::pair<Pose2, Twist2>> cases{
      {Pose2{}, Twist2{}},                                  // identity, zero twist
      {Pose2{}, Twist2{{0.3, 0.1}, 1e-7}},                  // near-zero rotation (Taylor branch)
      {Pose2{{1.0, -2.0}, 0.4}, Twist2{{0.0, 0.0}, 2.0}}};  // pure rotation
  for (int k = 0; k < 20; ++k) {
    std::uniform_real_distribution<double> d(-3.0, 3.0);
    cases.push_back({Pose2{{d(rng), d(rng)}, d(rng)}, test::random_twist(rng)});
  }
  for (const auto& c : cases) {
    // Named copies: clang 14 (the sanitizer pass) cannot capture structured bindings.
    const Pose2 pose = c.first;
    const Twist2 twist = c.second;
    for (double dt : {0.01, 0.5}) {
      const auto f_pose = [&](const Eigen::Vector3d& x) {
        return vec(integrate_exact(pose_of(x), twist, dt));
      };
      const auto f_twist = [&](const Eigen::Vector3d& x) {
        return vec(integrate_exact(pose, Twist2::from_vector(x), dt));
      };
      const Eigen::Matrix3d nf = test::numerical_jacobian<3, 3>(f_pose, vec(pose));
      const Eigen::Matrix3d ng = test::numerical_jacobian<3, 3>(f_twist, twist.vector());
      // Central differences with h = 1e-6: error ~h^2 * third derivative + 1e-16/h.
      EXPECT_LT((nf - exact_step_pose_jacobian(pose, twist, dt)).cwiseAbs().maxCoeff(), 1e-8);
      EXPECT_LT((ng - exact_step_twist_jacobian(pose, twist, dt)).cwiseAbs().maxCoeff(), 1e-8);
    }
  }
}

TEST(Se2, DegreesAndRadiansAreInverseAndExactAtRightAngles) {
  EXPECT_DOUBLE_EQ(to_degrees(std::numbers::pi / 2), 90.0);
  EXPECT_DOUBLE_EQ(to_radians(180.0), std::numbers::pi);
  for (const double x : {-7.5, -1.0, 0.0, 0.3, 2.0, 100.0}) {
    EXPECT_NEAR(to_radians(to_degrees(x)), x, 1e-15 * std::max(1.0, std::abs(x)));
  }
}

}  // namespace
}  // namespace moa
