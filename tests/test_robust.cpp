// Sekimori & Miyazaki's voting and the consensus estimator against
// hand-built samples with one, two and three bad sensors.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <numbers>
#include <random>

#include "moa/core/chi2.hpp"
#include "moa/core/consensus.hpp"
#include "moa/core/sekimori.hpp"

namespace moa {
namespace {

constexpr double kDt = 0.01;

/// Sekimori & Miyazaki's layout: four sensors, x axis radial at 45 + k 90 deg, 0.1 m out.
SensorArray sekimori_array() {
  std::vector<SensorMount> m(4);
  for (int k = 0; k < 4; ++k) {
    const double phi = std::numbers::pi / 4.0 + k * std::numbers::pi / 2.0;
    m[static_cast<std::size_t>(k)].position = 0.1 * Eigen::Vector2d(std::cos(phi), std::sin(phi));
    m[static_cast<std::size_t>(k)].yaw = phi;
  }
  return SensorArray(m);
}

ArraySample clean_sample(const SensorArray& a, const Twist2& x) {
  ArraySample s;
  s.dt = kDt;
  s.t = 1.0;
  s.size = a.size();
  for (int i = 0; i < a.size(); ++i) {
    const auto u = static_cast<std::size_t>(i);
    s.counts[u] = a[i].counts(x, kDt);
    s.squal[u] = 255;
  }
  return s;
}

/// Adds a robot-frame point-velocity error (m/s) to sensor i's counts.
void corrupt(const SensorArray& a, ArraySample& s, int i, const Eigen::Vector2d& error) {
  s.counts[static_cast<std::size_t>(i)] += a[i].counts_from_robot_velocity() * error * kDt;
}

const Twist2 kTruth{{0.25, -0.1}, 0.8};

TEST(Sekimori, PairResidualIsLeastSquaresResidualOfEq4) {
  // Independent computation with a dynamic pseudo-inverse, as eq. (5) is written.
  const SensorArray a = sekimori_array();
  auto est = std::get<SekimoriEstimator>(SekimoriEstimator::create(a));
  std::mt19937_64 rng(30);
  std::normal_distribution<double> g(0.0, 0.01);
  ArraySample s = clean_sample(a, kTruth);
  for (int i = 0; i < 4; ++i) corrupt(a, s, i, {g(rng), g(rng)});
  ASSERT_TRUE(est.estimate(s).has_value());
  for (int i = 0; i < 4; ++i) {
    for (int j = i + 1; j < 4; ++j) {
      Eigen::MatrixXd big_a(4, 3);
      big_a.topRows(2) = a[i].point_jacobian();
      big_a.bottomRows(2) = a[j].point_jacobian();
      Eigen::VectorXd d(4);
      d << a[i].robot_velocity_from_counts() * s.counts[static_cast<std::size_t>(i)],
          a[j].robot_velocity_from_counts() * s.counts[static_cast<std::size_t>(j)];
      const Eigen::VectorXd u = big_a.completeOrthogonalDecomposition().pseudoInverse() * d;
      EXPECT_NEAR(est.pair_residual(i, j), (big_a * u - d).squaredNorm(), 1e-15);
    }
  }
}

TEST(Sekimori, OneBadSensorIsVotedOut) {
  const SensorArray a = sekimori_array();
  auto est = std::get<SekimoriEstimator>(SekimoriEstimator::create(a));
  EXPECT_EQ(est.r_th(), 2);
  ArraySample s = clean_sample(a, kTruth);
  corrupt(a, s, 2, {0.2, -0.1});
  const auto e = est.estimate(s);
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->source, Source::kMice);
  EXPECT_EQ(e->estimate.used, 0b1011u);
  EXPECT_EQ(e->excluded[2], Exclusion::kUnreliable);
  EXPECT_TRUE(e->estimate.twist.vector().isApprox(kTruth.vector(), 1e-9));
}

TEST(Sekimori, TwoOrThreeBadSensorsFallBackToWheels) {
  // With r_th = N - 2 = 2, two bad sensors leave each good one a single vote.
  const SensorArray a = sekimori_array();
  auto est = std::get<SekimoriEstimator>(SekimoriEstimator::create(a));
  const Twist2 wheels{{0.24, -0.09}, 0.75};
  for (int bad : {2, 3}) {
    ArraySample s = clean_sample(a, kTruth);
    for (int i = 0; i < bad; ++i) corrupt(a, s, i, {0.1 * (i + 1), -0.2 * i + 0.05});
    const auto e = est.estimate(s, wheels);
    ASSERT_TRUE(e.has_value());
    EXPECT_EQ(e->source, Source::kWheels) << bad;
    EXPECT_EQ(e->estimate.twist.vector(), wheels.vector());
    EXPECT_EQ(e->estimate.used, 0u);
    // Without wheels the last good twist is held, covariance grown.
    const auto held = est.estimate(s);
    EXPECT_EQ(held->source, Source::kHold);
  }
}

/// V_i = S_i + A_i Cov_(-i) A_i^T: covariance of sensor i's deleted residual
/// (its velocity predicted from the other sensors), dynamic matrices.
Eigen::Matrix2d deleted_residual_covariance(const SensorArray& a, int i,
                                            const std::vector<Eigen::Matrix2d>& s) {
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
  for (int j = 0; j < a.size(); ++j) {
    if (j == i) continue;
    normal += a[j].point_jacobian().transpose() * s[static_cast<std::size_t>(j)].inverse() *
              a[j].point_jacobian();
  }
  return s[static_cast<std::size_t>(i)] +
         a[i].point_jacobian() * normal.inverse() * a[i].point_jacobian().transpose();
}

TEST(Consensus, NeverUsesSensorWithErrorBeyondFiveSigma) {
  // Good sensors noise-free, one sensor off by an error whose whitened
  // deleted residual is >= 5 sigma (e^T V^-1 e >= 25). That is the
  // detectable part of an error: the other sensors' fit absorbs the rest.
  const SensorArray a = sekimori_array();
  ConsensusOptions options;
  options.noise.relative = 0.0;  // quantisation only: S_i = C C^T / (6 dt^2)
  std::vector<Eigen::Matrix2d> s_cov;
  for (int i = 0; i < 4; ++i) {
    const Eigen::Matrix2d c = a[i].robot_velocity_from_counts();
    s_cov.push_back(c * c.transpose() / 6.0 / (kDt * kDt));
  }
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> angle(0.0, 2.0 * std::numbers::pi), sigmas(5.0, 50.0);
  for (int trial = 0; trial < 200; ++trial) {
    auto est = std::get<ConsensusEstimator>(ConsensusEstimator::create(a, options));
    const int bad = trial % 4;
    const Eigen::Matrix2d v = deleted_residual_covariance(a, bad, s_cov);
    const double phi = angle(rng);
    const Eigen::Vector2d dir(std::cos(phi), std::sin(phi));
    const Eigen::Vector2d error = dir * sigmas(rng) / std::sqrt(dir.dot(v.inverse() * dir));
    ASSERT_GE(error.dot(v.inverse() * error), 25.0 - 1e-9);
    ArraySample sample = clean_sample(a, {});  // robot still: no speed-dependent noise
    corrupt(a, sample, bad, error);
    const auto e = est.estimate(sample);
    ASSERT_TRUE(e.has_value());
    EXPECT_FALSE(contains(e->estimate.used, bad)) << "trial " << trial;
    EXPECT_EQ(e->excluded[static_cast<std::size_t>(bad)], Exclusion::kInconsistent);
    EXPECT_EQ(count_sensors(e->estimate.used), 3);
    EXPECT_LT(e->estimate.twist.vector().norm(), 1e-9);
  }
}

TEST(Consensus, TwoBadSensorsLeaveTheGoodPair) {
  const SensorArray a = sekimori_array();
  auto est = std::get<ConsensusEstimator>(ConsensusEstimator::create(a));
  ArraySample s = clean_sample(a, kTruth);
  corrupt(a, s, 0, {0.3, 0.1});
  corrupt(a, s, 3, {-0.2, 0.25});
  const auto e = est.estimate(s);
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->source, Source::kMice);
  EXPECT_EQ(e->estimate.used, 0b0110u);
  EXPECT_TRUE(e->estimate.twist.vector().isApprox(kTruth.vector(), 1e-6));
}

TEST(Consensus, ThreeBadSensorsFallBackToWheelsAndRelease) {
  const SensorArray a = sekimori_array();
  auto est = std::get<ConsensusEstimator>(ConsensusEstimator::create(a));
  const Twist2 wheels{{0.26, -0.1}, 0.82};
  ASSERT_EQ(est.estimate(clean_sample(a, kTruth), wheels)->source, Source::kMice);
  ArraySample s = clean_sample(a, kTruth);
  corrupt(a, s, 0, {0.3, 0.1});
  corrupt(a, s, 1, {-0.2, 0.25});
  corrupt(a, s, 3, {0.05, -0.3});
  const auto e = est.estimate(s, wheels);
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->source, Source::kWheels);
  EXPECT_EQ(e->estimate.used, 0u);
  EXPECT_EQ(e->excluded[2], Exclusion::kFallback);
  // Engages without wheels as a hold with grown covariance...
  const auto held = est.estimate(s);
  EXPECT_EQ(held->source, Source::kHold);
  // ...and releases as soon as the sensors agree again.
  const auto back = est.estimate(clean_sample(a, kTruth), wheels);
  EXPECT_EQ(back->source, Source::kMice);
  EXPECT_EQ(back->estimate.used, 0b1111u);
}

TEST(Consensus, LiftedSensorIsExcludedWithReason) {
  const SensorArray a = sekimori_array();
  auto est = std::get<ConsensusEstimator>(ConsensusEstimator::create(a));
  ArraySample s = clean_sample(a, kTruth);
  s.flags[1] = kFlagLift;
  const auto e = est.estimate(s);
  EXPECT_EQ(e->excluded[1], Exclusion::kLift);
  EXPECT_EQ(e->estimate.used, 0b1101u);
}

TEST(Consensus, MinorityPairMustAgreeWithWheels) {
  // Two sensors lose track identically (counts zero: a consistent "still"
  // pair), the other two see the motion. Without wheels both pairs pass and
  // the smaller residual wins; with wheels the pair that agrees is chosen.
  const SensorArray a = sekimori_array();
  auto est = std::get<ConsensusEstimator>(ConsensusEstimator::create(a));
  ArraySample s = clean_sample(a, kTruth);
  s.counts[0].setZero();
  s.counts[1].setZero();
  const auto e = est.estimate(s, kTruth);
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->estimate.used, 0b1100u);
  EXPECT_TRUE(e->estimate.twist.vector().isApprox(kTruth.vector(), 1e-6));
}

TEST(Consensus, PairThatUnderReadsAlikeNeedsThePriorsCorroboration) {
  // Sensors 0 and 1 both read half their counts: they fit each other exactly
  // (twist 0.5 x), and their relative-noise covariance is wide. Sensors 2
  // and 3 are corrupted differently, so no three agree. The step from the
  // trusted twist x is 0.5 |x| = 0.135 m/s in 10 ms, 13.5 m/s^2: beyond
  // the default 2 m/s^2 by far, so the prior refuses the pair and the
  // estimator holds. Without the prior the pair is taken.
  const SensorArray a = sekimori_array();
  ArraySample bad = clean_sample(a, kTruth);
  bad.t += kDt;
  for (int i = 0; i < 2; ++i) {
    const auto u = static_cast<std::size_t>(i);
    bad.counts[u] = a[i].counts(Twist2{0.5 * kTruth.v, 0.5 * kTruth.omega}, kDt);
  }
  corrupt(a, bad, 2, {0.3, 0.1});
  corrupt(a, bad, 3, {-0.2, 0.25});
  for (const bool prior : {true, false}) {
    ConsensusOptions o;
    o.motion_prior = prior;
    auto est = std::get<ConsensusEstimator>(ConsensusEstimator::create(a, o));
    ASSERT_EQ(est.estimate(clean_sample(a, kTruth))->estimate.used, 0b1111u);
    const auto e = est.estimate(bad);
    ASSERT_TRUE(e.has_value());
    if (prior) {
      EXPECT_EQ(e->source, Source::kHold);
      EXPECT_EQ(e->excluded[0], Exclusion::kFallback);
    } else {
      EXPECT_EQ(e->source, Source::kMice);
      EXPECT_EQ(e->estimate.used, 0b0011u);
    }
  }
}

TEST(Consensus, PairWithinTheRobotsLimitsPassesThePrior) {
  // The same two faulty sensors, the good pair 2-3 after an acceleration at
  // the limit (2 m/s^2 for 10 ms, well inside the gate of about 4 sd).
  const SensorArray a = sekimori_array();
  auto est = std::get<ConsensusEstimator>(ConsensusEstimator::create(a));
  ASSERT_EQ(est.estimate(clean_sample(a, kTruth))->estimate.used, 0b1111u);
  const Twist2 faster{kTruth.v + Eigen::Vector2d(RobotLimits{}.accel * kDt, 0.0), kTruth.omega};
  ArraySample s = clean_sample(a, faster);
  s.t += kDt;
  corrupt(a, s, 0, {0.3, 0.1});
  corrupt(a, s, 1, {-0.2, 0.25});
  const auto e = est.estimate(s);
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->source, Source::kMice);
  EXPECT_EQ(e->estimate.used, 0b1100u);
  EXPECT_TRUE(e->estimate.twist.vector().isApprox(faster.vector(), 1e-6));
}

/// Sensors 0 and 2 of Sekimori & Miyazaki's layout: a pair 0.2 m apart.
SensorArray opposite_pair() {
  const SensorArray four = sekimori_array();
  return SensorArray(std::vector<SensorMount>{four[0], four[2]});
}

TEST(Consensus, APairTheNoiseModelCannotExplainIsFusedWhenThePriorAdmitsIt) {
  // Two sensors that disagree by 40 mm/s (a latency under acceleration, a
  // mount error): no subset passes, yet their fit is a twist the robot's
  // limits admit. It is reported, its covariance grown by chi2 / dof,
  // rather than the hold's stale twist.
  const SensorArray a = opposite_pair();
  auto est = std::get<ConsensusEstimator>(ConsensusEstimator::create(a));
  const auto first = est.estimate(clean_sample(a, kTruth));
  ASSERT_EQ(first->estimate.used, 0b11u);
  ArraySample s = clean_sample(a, kTruth);
  s.t += kDt;
  corrupt(a, s, 0, {0.04, 0.0});
  const auto e = est.estimate(s);
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->source, Source::kMice);
  EXPECT_EQ(e->estimate.used, 0b11u);
  // The fit of both against the clean fit: the reported covariance is the
  // fit's grown by chi2 / 1 (1 dof), over the gate q(1 - 1e-3, 1) = 10.8.
  const real grown = e->estimate.covariance.trace() / first->estimate.covariance.trace();
  EXPECT_GT(grown, chi2_quantile(1.0 - 1e-3, 1) * 0.9);
  // Within 4 sd (grown) of the truth.
  const Vec3 d = e->estimate.twist.vector() - kTruth.vector();
  EXPECT_LT(d.dot(e->estimate.covariance.inverse() * d), 16.0);
}

TEST(Consensus, APairWithOneSensorReadingZeroIsHeldWhenThePriorRefusesItsFit) {
  // The same pair, sensor 0 reading zero at 0.27 m/s: the pair's fit (about
  // half the motion) is far outside what the robot can do in 10 ms.
  const SensorArray a = opposite_pair();
  auto est = std::get<ConsensusEstimator>(ConsensusEstimator::create(a));
  ASSERT_EQ(est.estimate(clean_sample(a, kTruth))->estimate.used, 0b11u);
  ArraySample s = clean_sample(a, kTruth);
  s.t += kDt;
  s.counts[0] = Vec2::Zero();
  const auto e = est.estimate(s);
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->source, Source::kHold);
  EXPECT_EQ(e->estimate.used, 0u);
}

/// Every sensor reads zero at time t (the array lost the floor together).
ArraySample dropout_sample(const SensorArray& a, double t) {
  ArraySample s = clean_sample(a, Twist2{});
  s.t = t;
  return s;
}

TEST(Consensus, CommonModeDropoutIsBridgedByTheWheelsAndReleased) {
  // All four sensors read zero for 0.3 s while the robot turns and the
  // wheels go on seeing the motion: four sensors that agree pass every test
  // among themselves, only the references can reject them.
  const SensorArray a = sekimori_array();
  auto est = std::get<ConsensusEstimator>(ConsensusEstimator::create(a));
  const Twist2 wheels{{0.26, -0.1}, 0.82};
  double t = 1.0;
  for (int k = 0; k < 5; ++k, t += kDt) {
    ArraySample s = clean_sample(a, kTruth);
    s.t = t;
    const auto e = est.estimate(s, wheels);
    ASSERT_EQ(e->source, Source::kMice) << "epoch " << k << " " << to_name(e->excluded[0]);
  }
  for (int k = 0; k < 30; ++k, t += kDt) {
    const auto e = est.estimate(dropout_sample(a, t), wheels);
    ASSERT_TRUE(e.has_value());
    EXPECT_EQ(e->source, Source::kWheels) << "epoch " << k;
    EXPECT_EQ(e->estimate.used, 0u);
    // The status record: both references over their gate.
    EXPECT_GT(e->tests.wheels, 1.0);
    EXPECT_GT(e->tests.prior, 1.0);
    for (int i = 0; i < 4; ++i)
      EXPECT_EQ(e->excluded[static_cast<std::size_t>(i)], Exclusion::kCommonMode);
  }
  ArraySample back = clean_sample(a, kTruth);
  back.t = t;
  const auto e = est.estimate(back, wheels);
  EXPECT_EQ(e->source, Source::kMice);
  EXPECT_EQ(e->estimate.used, 0b1111u);
}

TEST(Consensus, TestRatiosAreTheWhitenedResidualsOverTheirGates) {
  // One sensor off by 0.05 m/s (then 0.1 m/s) on its x axis, the others
  // exact: the others fit the twist exactly, so their ratios are zero, and
  // the bad one's is e^T S^-1 e / q(1 - 1e-3, 2), above its gate and
  // quadratic in e (doubling e about quadruples it; S grows a little with
  // the speed the sensor reports).
  const SensorArray a = sekimori_array();
  std::array<double, 2> ratio{};
  for (int j = 0; j < 2; ++j) {
    auto est = std::get<ConsensusEstimator>(ConsensusEstimator::create(a));
    ArraySample s = clean_sample(a, kTruth);
    corrupt(a, s, 2, {0.05 * (j + 1), 0.0});
    const auto e = est.estimate(s, kTruth);
    ASSERT_EQ(e->excluded[2], Exclusion::kInconsistent);
    ratio[static_cast<std::size_t>(j)] = e->tests.sensor[2];
    EXPECT_GT(e->tests.sensor[2], 1.0);
    for (int i : {0, 1, 3}) EXPECT_LT(e->tests.sensor[static_cast<std::size_t>(i)], 1e-6);
    EXPECT_LE(e->tests.wheels, 1.0);
    EXPECT_TRUE(std::isnan(e->tests.prior));  // no prior before the first trusted twist
  }
  // Quadratic in the error, but S grows with the reported speed a little.
  EXPECT_NEAR(ratio[1] / ratio[0], 4.0, 0.5);
}

TEST(Consensus, CommonModeNeedsEveryReferenceToDisagree) {
  // A hard stop the wheels confirm is the robot's, not the array's: the
  // prior alone rejects it (0.27 m/s and 0.8 rad/s in 10 ms), the wheels
  // accept it, so the array is used. And with the test off the standstill
  // is taken whatever the wheels say.
  const SensorArray a = sekimori_array();
  {
    auto est = std::get<ConsensusEstimator>(ConsensusEstimator::create(a));
    ASSERT_EQ(est.estimate(clean_sample(a, kTruth), kTruth)->source, Source::kMice);
    const auto e = est.estimate(dropout_sample(a, 1.0 + kDt), Twist2{});
    EXPECT_EQ(e->source, Source::kMice);
    EXPECT_EQ(e->estimate.used, 0b1111u);
  }
  {
    ConsensusOptions o;
    o.common_mode = false;
    auto est = std::get<ConsensusEstimator>(ConsensusEstimator::create(a, o));
    ASSERT_EQ(est.estimate(clean_sample(a, kTruth), kTruth)->source, Source::kMice);
    EXPECT_EQ(est.estimate(dropout_sample(a, 1.0 + kDt), kTruth)->source, Source::kMice);
  }
}

TEST(Consensus, CommonModeWithoutWheelsHoldsOnlyWhileThePriorIsTight) {
  // Without wheels the prior is the only reference, and it widens by the
  // acceleration limits while the estimator holds: the standstill is
  // rejected while |0 - x|^2 over the prior's growth (a e, a e, alpha e),
  // the trusted twist's covariance neglected, exceeds q(1 - 1e-3, 3); it
  // is accepted once that falls below the quantile.
  const SensorArray a = sekimori_array();
  auto est = std::get<ConsensusEstimator>(ConsensusEstimator::create(a));
  const RobotLimits lim;
  const double q = chi2_quantile(1.0 - 1e-3, 3);
  ArraySample first = clean_sample(a, kTruth);
  ASSERT_EQ(est.estimate(first)->source, Source::kMice);
  int held = 0;
  int expected = 0;
  for (int k = 1; k <= 20; ++k) {
    const double e = k * kDt;
    const double m = kTruth.v.squaredNorm() / std::pow(lim.accel * e, 2) +
                     std::pow(kTruth.omega / (lim.angular_accel * e), 2);
    if (m > q) ++expected;
    const auto r = est.estimate(dropout_sample(a, first.t + e));
    if (r->source == Source::kHold) {
      ++held;
      EXPECT_EQ(r->excluded[0], Exclusion::kCommonMode);
    } else {
      break;
    }
  }
  EXPECT_GE(held, 1);
  EXPECT_NEAR(held, expected, 1);
}

TEST(Consensus, CommonModeBridgeEndsAfterMaxBridge) {
  // Wheels spinning against a wall look like an array over a bump: the
  // bridge is not latched beyond max_bridge.
  const SensorArray a = sekimori_array();
  ConsensusOptions o;
  o.max_bridge = 0.2;
  auto est = std::get<ConsensusEstimator>(ConsensusEstimator::create(a, o));
  ArraySample first = clean_sample(a, kTruth);
  ASSERT_EQ(est.estimate(first, kTruth)->source, Source::kMice);
  int bridged = 0;
  for (int k = 1; k <= 40; ++k) {
    if (est.estimate(dropout_sample(a, first.t + k * kDt), kTruth)->source == Source::kWheels) {
      ++bridged;
    }
  }
  // Epochs up to 0.2 s after the last trusted one (rounding of t aside).
  EXPECT_GE(bridged, 19);
  EXPECT_LE(bridged, 20);
}

TEST(Consensus, MinorityIsJudgedWithTheWheelCovarianceAlone) {
  // Wheels 0.04 m/s off the truth (inside their sd of 0.047 m/s, 0.13
  // rad/s), the faulty pair reads 0.5 x: (-0.165, 0.05, -0.4) from the
  // wheels, a distance of about 23 with the wheel covariance alone (gate
  // q(0.999, 3) = 16.3), about 10 with the pair's covariance added (sensor
  // noise 0.05 m/s per axis: twist sd about 0.035 m/s, 0.35 rad/s).
  SensorArray a = sekimori_array();
  std::vector<SensorMount> m(a.mounts().begin(), a.mounts().end());
  for (auto& s : m) s.noise = 0.05;  // m/s per axis: a wide pair covariance
  a = SensorArray(m);
  const Twist2 wheels{kTruth.v + Eigen::Vector2d(0.04, 0.0), kTruth.omega};
  ArraySample bad = clean_sample(a, kTruth);
  for (int i = 0; i < 2; ++i) {
    const auto u = static_cast<std::size_t>(i);
    bad.counts[u] = a[i].counts(Twist2{0.5 * kTruth.v, 0.5 * kTruth.omega}, kDt);
  }
  corrupt(a, bad, 2, {0.9, 0.3});
  corrupt(a, bad, 3, {-0.6, 0.75});
  for (const bool prior : {true, false}) {
    ConsensusOptions o;
    o.motion_prior = prior;
    auto est = std::get<ConsensusEstimator>(ConsensusEstimator::create(a, o));
    const auto e = est.estimate(bad, wheels);  // first sample: no prior yet
    ASSERT_TRUE(e.has_value());
    EXPECT_EQ(e->source, prior ? Source::kWheels : Source::kMice);
  }
}

/// Epoch k of a motion whose twist varies from epoch to epoch (so that no
/// good sensor repeats its counts exactly).
ArraySample varying_sample(const SensorArray& a, int k, double amplitude = 0.05) {
  const double f = 1.0 + amplitude * std::sin(0.3 * k);
  ArraySample s = clean_sample(a, Twist2{f * kTruth.v, f * kTruth.omega});
  s.t = 1.0 + k * kDt;
  return s;
}

/// The drift test's alarm level h (sd), solved from Siegmund's in-control
/// run length independently of the monitor, and the most one epoch moves a
/// statistic, clip - k (z clipped to sqrt(q(1 - alpha, 2)) = sqrt(-2 ln alpha)).
struct CusumBound {
  double h = 0.0, step = 0.0;
  /// No alarm before this many fed epochs.
  int fewest() const { return static_cast<int>(std::floor(h / step)); }
};
CusumBound cusum_bound(const ConsensusOptions& o) {
  const double k = o.health.drift_shift;
  const double arl = 4.0 * o.health.drift_false_alarm_time / kDt;
  double hp = 0.0;  // smallest h' (step 1e-4) whose run length reaches arl
  while ((std::exp(2 * k * hp) - 2 * k * hp - 1) / (2 * k * k) < arl) hp += 1e-4;
  return {hp - 1.166, std::sqrt(-2.0 * std::log(o.alpha)) - k};
}

TEST(Health, FrozenSensorIsNamedFrozenAndReturnsOnceItsReadingsAreFresh) {
  // The twist varies by +-20 %: from k = 20 sensor 1 repeats its counts,
  // which soon disagree with the motion. The drift test's alarm (not before
  // its fewest epochs) is named frozen by the repeats. At k = 100 the counts
  // move again: the hypothesis is refuted, and the sensor is back after
  // drift_release_time of fresh samples and the probation.
  const SensorArray a = sekimori_array();
  const ConsensusOptions o;
  const CusumBound bound = cusum_bound(o);
  auto est = std::get<ConsensusEstimator>(ConsensusEstimator::create(a, o));
  ArraySample frozen;
  int first_frozen = -1, first_back = -1;
  for (int k = 0; k < 200; ++k) {
    ArraySample s = varying_sample(a, k, 0.2);
    if (k == 20) frozen = s;
    if (k >= 20 && k < 100) s.counts[1] = frozen.counts[1];
    const auto e = est.estimate(s);
    ASSERT_TRUE(e.has_value());
    EXPECT_NE(e->excluded[1], Exclusion::kDrift) << k;  // named by its readings
    if (first_frozen < 0 && e->excluded[1] == Exclusion::kFrozen) first_frozen = k;
    if (first_frozen >= 0 && k < 100) {
      EXPECT_EQ(e->excluded[1], Exclusion::kFrozen) << k;  // while it repeats
    }
    if (k >= 100 && first_back < 0 && contains(e->estimate.used, 1)) first_back = k;
  }
  EXPECT_GE(first_frozen, 20 + bound.fewest());
  EXPECT_LT(first_frozen, 40);  // the point speed changes 20 % in 10 epochs
  const int release = static_cast<int>(std::ceil(o.health.drift_release_time / kDt));
  const int probation = static_cast<int>(std::ceil(o.health.probation / kDt));
  EXPECT_GE(first_back, 100 + release + probation);
  EXPECT_LE(first_back, 100 + release + probation + 3);
}

TEST(Health, ZeroWhileTheOthersMoveIsNamedZero) {
  // Sensor 2 reads zero from k = 10: each epoch the consistency test leaves
  // it out, and the drift test's alarm, after the fewest epochs it allows
  // (each fed sample is clipped), names it zero.
  const SensorArray a = sekimori_array();
  const ConsensusOptions o;
  const CusumBound bound = cusum_bound(o);
  auto est = std::get<ConsensusEstimator>(ConsensusEstimator::create(a, o));
  int first_zero = -1;
  for (int k = 0; k < 50; ++k) {
    ArraySample s = varying_sample(a, k);
    if (k >= 10) s.counts[2].setZero();
    const auto e = est.estimate(s);
    ASSERT_TRUE(e.has_value());
    if (first_zero < 0 && e->excluded[2] == Exclusion::kZero) first_zero = k;
    if (k >= 10 && first_zero < 0) {
      EXPECT_EQ(e->excluded[2], Exclusion::kInconsistent) << k;
    }
    if (first_zero >= 0) {
      EXPECT_EQ(e->excluded[2], Exclusion::kZero) << k;
    }
  }
  // Fed from k = 10, judged the epoch after: at full clip the alarm comes
  // at the first whole step past h.
  EXPECT_GE(first_zero, 10 + bound.fewest());
  EXPECT_LE(first_zero, 10 + bound.fewest() + 2);
}

TEST(Health, DriftTooSmallForOneEpochIsExcludedOverTime) {
  // Sensor 3 reads 5 % short: 2.5 sd of the 2 % relative noise model, which
  // one epoch's chi-square over four sensors passes; its CUSUM against the
  // other three crosses h. Each epoch moves a statistic by at most
  // clip - k (z clipped to sqrt(q(1 - alpha, 2)) = sqrt(-2 ln alpha)), so
  // not before h / (clip - k) epochs, with h solved here from Siegmund's
  // run length independently of the monitor. Without the monitor it is
  // used throughout.
  const SensorArray a = sekimori_array();
  for (const bool enabled : {true, false}) {
    ConsensusOptions o;
    o.health.enabled = enabled;
    auto est = std::get<ConsensusEstimator>(ConsensusEstimator::create(a, o));
    int first_drift = -1;
    for (int k = 0; k < 150; ++k) {
      ArraySample s = varying_sample(a, k);
      s.counts[3] *= 0.95;
      const auto e = est.estimate(s);
      ASSERT_TRUE(e.has_value());
      // Consistent in one epoch (from the second: the first has no predicted
      // speed for the relative noise).
      if (k == 1) {
        EXPECT_EQ(e->estimate.used, 0b1111u);
      }
      if (first_drift < 0 && e->excluded[3] == Exclusion::kDrift) first_drift = k;
      if (k == 149 && enabled) {
        EXPECT_EQ(e->estimate.used, 0b0111u);
        const double f = 1.0 + 0.05 * std::sin(0.3 * k);
        EXPECT_TRUE(e->estimate.twist.vector().isApprox(f * kTruth.vector(), 1e-9));
      }
    }
    if (enabled) {
      EXPECT_GE(first_drift, cusum_bound(o).fewest());
      EXPECT_LT(first_drift, 149);
    } else {
      EXPECT_EQ(first_drift, -1);
    }
  }
}

TEST(Consensus, NoiseFlagsMarkOverSpeedLowSqualAndOverflow) {
  SensorArray a = sekimori_array();
  for (int i = 0; i < 4; ++i) a[i].max_speed = 0.3556;
  auto est = std::get<ConsensusEstimator>(ConsensusEstimator::create(a));
  const Twist2 fast{{0.5, 0.0}, 0.0};
  est.estimate(clean_sample(a, fast));  // predicts the speed of the next sample
  ArraySample s = clean_sample(a, fast);
  s.squal[1] = 3;
  s.flags[2] = kFlagOverflow;
  const auto e = est.estimate(s);
  EXPECT_TRUE(e->noise_flags[0] & kNoiseOverSpeed);
  EXPECT_TRUE(e->noise_flags[1] & kNoiseLowSqual);
  EXPECT_TRUE(e->noise_flags[2] & kNoiseOverflow);
}

TEST(Chi2, QuantilesMatchKnownValues) {
  // Table values of the chi-square distribution (independent of the code).
  EXPECT_NEAR(chi2_quantile(0.95, 1), 3.841459, 1e-5);
  EXPECT_NEAR(chi2_quantile(0.999, 1), 10.827566, 1e-5);
  EXPECT_NEAR(chi2_quantile(0.999, 5), 20.515006, 1e-5);
  EXPECT_NEAR(chi2_quantile(0.99, 29), 49.587884, 1e-5);
  // Beyond kChi2LargeDof, Wilson-Hilferty: the table's 1106.969 at 1000 dof.
  EXPECT_NEAR(chi2_quantile(0.99, 1000), 1106.969, 0.05);
  // Where it takes over, its upper 1e-6 quantile leaves a tail within 10 %
  // of 1e-6 by the incomplete gamma function.
  const int dof = kChi2LargeDof + 1;
  EXPECT_NEAR(1.0 - chi2_cdf(chi2_quantile(1.0 - 1e-6, dof), dof), 1e-6, 1e-7);
  // dof 2 has a closed form: P(x) = 1 - exp(-x/2).
  EXPECT_NEAR(chi2_cdf(3.0, 2), 1.0 - std::exp(-1.5), 1e-13);
}

}  // namespace
}  // namespace moa
