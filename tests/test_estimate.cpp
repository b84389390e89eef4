#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <numbers>
#include <random>

#include "moa/core/dead_reckoner.hpp"
#include "moa/core/estimate.hpp"
#include "support/checks.hpp"

namespace moa {
namespace {

LsEstimator build(const SensorArray& a, double dt = 0.01) {
  auto built = LsEstimator::create(a, all_sensors(a.size()), dt);
  EXPECT_TRUE(std::holds_alternative<LsEstimator>(built))
      << describe(std::get<GeometryError>(built));
  return std::get<LsEstimator>(std::move(built));
}

ArraySample sample_of(const SensorArray& a, const Twist2& x, double dt) {
  ArraySample s;
  s.dt = dt;
  s.size = a.size();
  for (int i = 0; i < a.size(); ++i) s.counts[static_cast<std::size_t>(i)] = a[i].counts(x, dt);
  return s;
}

TEST(LsEstimator, RecoversTwistExactlyForRandomGeometries) {
  std::mt19937_64 rng(10);
  for (int trial = 0; trial < 200; ++trial) {
    const int n = 2 + static_cast<int>(rng() % 7);  // 2..8
    std::vector<SensorMount> mounts;
    for (int i = 0; i < n; ++i) mounts.push_back(test::random_mount(rng));
    const SensorArray a(mounts);
    const LsEstimator est = build(a);
    const Twist2 x = test::random_twist(rng);
    const auto e = est.estimate(sample_of(a, x, 0.01));
    ASSERT_TRUE(e.has_value());
    EXPECT_TRUE(e->twist.vector().isApprox(x.vector(), 1e-9)) << "n = " << n;
  }
}

TEST(LsEstimator, GainEqualsWeightedPseudoInverse) {
  // Independent computation on dynamic matrices: B = (A^T W A)^-1 A^T W.
  std::mt19937_64 rng(11);
  std::vector<SensorMount> mounts;
  std::uniform_real_distribution<double> noise(0.001, 0.02);
  for (int i = 0; i < 5; ++i) {
    mounts.push_back(test::random_mount(rng));
    mounts.back().noise = noise(rng);
  }
  const SensorArray a(mounts);
  const double dt = 0.005;
  const LsEstimator est = build(a, dt);
  Eigen::MatrixXd big_a(10, 3);
  Eigen::VectorXd w(10);
  for (int i = 0; i < 5; ++i) {
    big_a.middleRows(2 * i, 2) = a[i].point_jacobian();
    const Eigen::Matrix2d c = a[i].robot_velocity_from_counts();
    const double q = (c * c.transpose()).trace() / 12.0 / (dt * dt);
    w.segment(2 * i, 2).setConstant(1.0 / (*mounts[static_cast<std::size_t>(i)].noise *
                                               *mounts[static_cast<std::size_t>(i)].noise +
                                           q));
  }
  const Eigen::MatrixXd b =
      (big_a.transpose() * w.asDiagonal() * big_a).inverse() * big_a.transpose() * w.asDiagonal();
  EXPECT_TRUE(est.gain().isApprox(b, 1e-10));
}

TEST(LsEstimator, PolygonAverageEqualsLeastSquares) {
  std::mt19937_64 rng(12);
  std::normal_distribution<double> g(0.0, 0.3);
  for (int n = 3; n <= 8; ++n) {
    const double r = 0.05 + 0.05 * n, theta = 0.1 * n - 0.4;
    const SensorArray a = regular_polygon(n, r, theta);
    const LsEstimator est = build(a);
    for (int trial = 0; trial < 20; ++trial) {
      // Inconsistent point velocities: the average is still the LS solution.
      std::vector<Eigen::Vector2d> u(static_cast<std::size_t>(n));
      Eigen::VectorXd stacked(2 * n);
      for (int i = 0; i < n; ++i) {
        u[static_cast<std::size_t>(i)] = {g(rng), g(rng)};
        stacked.segment<2>(2 * i) = u[static_cast<std::size_t>(i)];
      }
      const Eigen::Vector3d ls = est.gain() * stacked;
      const Twist2 avg = average_regular_polygon(u, r, theta);
      EXPECT_LT((ls - avg.vector()).cwiseAbs().maxCoeff(), 1e-12) << "n = " << n;
    }
  }
}

TEST(LsEstimator, VarianceOfLinearVelocityIsSigmaSquaredOverN) {
  // Kim & Lee eq. (14). Noise sigma on every point-velocity axis; cpi so high
  // that quantisation is negligible (its variance ~1e-20 m^2/s^2).
  const double sigma = 0.01, dt = 0.01;
  const int trials = 20000;
  for (int n : {3, 4, 6}) {
    SensorMount proto;
    proto.cpi = 1e9;
    proto.noise = sigma;
    const SensorArray a = regular_polygon(n, 0.15, 0.2, proto);
    const LsEstimator est = build(a, dt);
    std::mt19937_64 rng(100 + n);
    std::normal_distribution<double> e(0.0, sigma);
    const Twist2 truth{{0.3, 0.0}, 0.0};
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Matrix3d sum_sq = Eigen::Matrix3d::Zero();
    for (int k = 0; k < trials; ++k) {
      ArraySample s = sample_of(a, truth, dt);
      for (int i = 0; i < n; ++i) {
        s.counts[static_cast<std::size_t>(i)] +=
            a[i].counts_from_robot_velocity() * Eigen::Vector2d(e(rng), e(rng)) * dt;
      }
      const Eigen::Vector3d x = est.estimate(s)->twist.vector() - truth.vector();
      sum += x;
      sum_sq += x * x.transpose();
    }
    const Eigen::Vector3d mean = sum / trials;
    const Eigen::Matrix3d cov = (sum_sq - trials * mean * mean.transpose()) / (trials - 1);
    // The sample variance has relative std. dev. sqrt(2 / (trials - 1)) = 1%;
    // 5 of them bounds a false failure at ~1e-6.
    const double tol = 5.0 * std::sqrt(2.0 / (trials - 1));
    const double expected = sigma * sigma / n;
    EXPECT_NEAR(cov(0, 0) / expected, 1.0, tol) << "n = " << n;
    EXPECT_NEAR(cov(1, 1) / expected, 1.0, tol) << "n = " << n;
    // The reported covariance is the same theory, including omega.
    const Eigen::Matrix3d reported = est.estimate(sample_of(a, truth, dt))->covariance;
    EXPECT_NEAR(reported(0, 0) / expected, 1.0, 1e-9);
    EXPECT_NEAR(cov(2, 2) / reported(2, 2), 1.0, tol);
    // Unbiased (Kim & Lee eq. (13)): mean within 5 standard errors.
    EXPECT_LT(std::abs(mean(0)), 5.0 * std::sqrt(expected / trials));
  }
}

TEST(LsEstimator, QuantisationCovarianceMatchesMonteCarlo) {
  // A count total over an interval is round(C_end) - round(C_start) of the
  // cumulative real count C. With the start phase and the fractional part
  // of the interval's count uniform, its error has variance 1/6 count^2.
  // The estimator is linear, so feeding it the count errors gives the twist error.
  const double dt = 0.01;
  const SensorArray a = regular_polygon(3, 0.1, 0.0);
  const LsEstimator est = build(a, dt);
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int trials = 20000;
  Eigen::Vector3d sum_sq = Eigen::Vector3d::Zero();
  ArraySample s = sample_of(a, {}, dt);
  for (int k = 0; k < trials; ++k) {
    for (int i = 0; i < 3; ++i) {
      for (int axis = 0; axis < 2; ++axis) {
        const double start = 100.0 * unit(rng), real = 63.0 + unit(rng);
        s.counts[static_cast<std::size_t>(i)](axis) =
            std::round(start + real) - std::round(start) - real;
      }
    }
    sum_sq += est.estimate(s)->twist.vector().cwiseAbs2();
  }
  const Eigen::Matrix3d reported = est.estimate(s)->covariance;
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_NEAR(sum_sq(axis) / trials / reported(axis, axis), 1.0, 5.0 * std::sqrt(2.0 / trials));
  }
}

TEST(LsEstimator, RankDeficientGeometryIsRejected) {
  SensorMount m;
  m.position = {0.1, 0.05};
  const auto error_of = [](const SensorArray& a, SensorMask mask) {
    const auto built = LsEstimator::create(a, mask, 0.01);
    return std::holds_alternative<GeometryError>(built) ? std::get<GeometryError>(built)
                                                        : static_cast<GeometryError>(-1);
  };
  // One sensor.
  EXPECT_EQ(error_of(SensorArray({m}), 1u), GeometryError::kTooFewSensors);
  // All sensors at one point, whatever their yaw: rotation is not observable.
  SensorMount turned = m;
  turned.yaw = 1.0;
  EXPECT_EQ(error_of(SensorArray({m, turned, m}), 7u), GeometryError::kRankDeficient);
  // A good array but a mask of one.
  const SensorArray good = regular_polygon(4, 0.1, 0.0);
  EXPECT_EQ(error_of(good, 0b0100u), GeometryError::kTooFewSensors);
  EXPECT_EQ(error_of(good, 0b10000u), GeometryError::kTooManySensors);
  SensorArray bad = good;
  bad[2].cpi = 0.0;
  EXPECT_EQ(error_of(bad, 0b1111u), GeometryError::kInvalidMount);
  bad[2].cpi = 800.0;
  bad[2].scale.y() = std::nan("");
  EXPECT_EQ(error_of(bad, 0b1111u), GeometryError::kInvalidMount);
  // Two distinct points are enough.
  EXPECT_TRUE(std::holds_alternative<LsEstimator>(LsEstimator::create(good, 0b0101u, 0.01)));
  EXPECT_NE(std::string(describe(GeometryError::kRankDeficient)).find("rank-deficient"),
            std::string::npos);
}

TEST(LsEstimator, SampleWithoutValidIntervalGivesNoEstimate) {
  const SensorArray a = regular_polygon(3, 0.1, 0.0);
  const LsEstimator est = build(a);
  ArraySample s = sample_of(a, {{0.1, 0.0}, 0.0}, 0.01);
  s.dt = 0.0;
  EXPECT_FALSE(est.estimate(s).has_value());
  s.dt = std::nan("");
  EXPECT_FALSE(est.estimate(s).has_value());
  s.dt = 0.01;
  s.size = 2;
  EXPECT_FALSE(est.estimate(s).has_value());
}

TEST(LsEstimator, SubsetUsesOnlyItsSensors) {
  // Garbage in the unused sensor does not reach the estimate.
  std::mt19937_64 rng(14);
  const SensorArray a = regular_polygon(4, 0.1, 0.3);
  const auto est = std::get<LsEstimator>(LsEstimator::create(a, 0b1011u, 0.01));
  const Twist2 x = test::random_twist(rng);
  ArraySample s = sample_of(a, x, 0.01);
  s.counts[2] = {1e6, -1e6};
  EXPECT_TRUE(est.estimate(s)->twist.vector().isApprox(x.vector(), 1e-9));
  EXPECT_EQ(est.estimate(s)->used, 0b1011u);
}

TEST(DeadReckoner, IntegratesExactly) {
  DeadReckoner r(Pose2{{1.0, 2.0}, 0.5});
  const Twist2 x{{0.3, 0.1}, 0.7};
  for (int k = 0; k < 10; ++k) r.step(x, 0.1);
  const Pose2 expected = Pose2{{1.0, 2.0}, 0.5} * exp(x, 1.0);
  EXPECT_TRUE(r.pose().t.isApprox(expected.t, 1e-12));
  EXPECT_NEAR(r.pose().theta, expected.theta, 1e-12);
}

}  // namespace
}  // namespace moa
