// The library pipeline (core/odometry.hpp) against the stages composed by
// hand, and its options, subsets, wheels, oracle and ordering rules.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "moa/core/dead_reckoner.hpp"
#include "moa/core/estimate.hpp"
#include "moa/core/odometry.hpp"
#include "moa/core/synchronise.hpp"
#include "support/synth.hpp"

namespace moa {
namespace {

struct Collected {
  std::vector<OdometryStep> steps;
  std::vector<ArraySample> samples;
  void operator()(const OdometryStep& s) {
    steps.push_back(s);
    samples.push_back(*s.sample);
  }
};

std::unique_ptr<Odometry> make(const SensorArray& array, const OdometryOptions& o,
                               double t0 = 0.0) {
  auto odometry = std::make_unique<Odometry>(array, t0, o);
  EXPECT_FALSE(odometry->geometry_error());
  return odometry;
}

void feed(Odometry& odometry, const test::SynthLog& log, Collected& out) {
  for (const auto& r : log.rows) {
    SensorRow row{r.t, r.sensor, r.counts, std::nullopt, 0};
    ASSERT_FALSE(odometry.push(row, out));
  }
  odometry.finish(log.rows.back().t, out);
}

TEST(Odometry, LeastSquaresEqualsTheStagesComposedByHand) {
  const SensorArray array = test::skewed_array();
  const auto log = test::synthesise(array, test::mixed_motion, 3.0, 0.013);
  OdometryOptions o;
  o.estimator = EstimatorKind::kLs;
  auto odometry = make(array, o);
  Collected out;
  feed(*odometry, log, out);

  // The same by hand: synchroniser, least squares, exact integration.
  Synchroniser sync(array.size(), 0.0, o.synchroniser());
  auto ls = std::get<LsEstimator>(LsEstimator::create(array, all_sensors(array.size()), 0.01));
  DeadReckoner reckoner;
  std::vector<Pose2> poses;
  const auto sink = [&](const ArraySample& s) {
    poses.push_back(reckoner.step(ls.estimate(s)->twist, s.dt));
  };
  for (const auto& r : log.rows)
    ASSERT_FALSE(sync.push(SensorRow{r.t, r.sensor, r.counts, std::nullopt, 0}, sink));
  sync.finish(log.rows.back().t, sink);

  ASSERT_EQ(out.steps.size(), poses.size());
  ASSERT_GT(poses.size(), 250u);
  for (std::size_t k = 0; k < poses.size(); ++k) {
    EXPECT_EQ(out.steps[k].pose.t.x(), poses[k].t.x()) << k;
    EXPECT_EQ(out.steps[k].pose.theta, poses[k].theta) << k;
    EXPECT_EQ(out.steps[k].estimate.estimate.used, all_sensors(array.size()));
  }
}

TEST(Odometry, ASubsetOfSensorsIsLeastSquaresOverThemAndTheRestUnselected) {
  const SensorArray array = test::skewed_array();
  const auto log = test::synthesise(array, test::mixed_motion, 2.0, 0.01);
  OdometryOptions o;
  o.estimator = EstimatorKind::kLs;
  o.sensors = 0b1010u;
  auto odometry = make(array, o);
  Collected out;
  feed(*odometry, log, out);
  auto ls = std::get<LsEstimator>(LsEstimator::create(array, 0b1010u, 0.01));
  ASSERT_FALSE(out.steps.empty());
  for (std::size_t k = 0; k < out.steps.size(); ++k) {
    const auto& step = out.steps[k];
    const auto expected = ls.estimate(out.samples[k]);
    ASSERT_TRUE(expected);
    EXPECT_NEAR(step.estimate.estimate.twist.v.x(), expected->twist.v.x(), 1e-12);
    EXPECT_NEAR(step.estimate.estimate.twist.omega, expected->twist.omega, 1e-12);
    EXPECT_EQ(step.estimate.estimate.used, 0b1010u);
    EXPECT_EQ(step.estimate.excluded[0], Exclusion::kUnselected);
    EXPECT_EQ(step.estimate.excluded[2], Exclusion::kUnselected);
  }
}

TEST(Odometry, OneSelectedSensorIsAGeometryError) {
  OdometryOptions o;
  o.sensors = 0b0001u;
  const Odometry odometry(test::skewed_array(), 0.0, o);
  EXPECT_EQ(odometry.geometry_error(), GeometryError::kTooFewSensors);
}

TEST(Odometry, WheelsEstimatorIntegratesTheWheelTwist) {
  // Wheel rows at 50 Hz of a constant twist; mice rows that say something
  // else entirely: the pose is the wheels' exact integral.
  const SensorArray array = test::skewed_array();
  OdometryOptions o;
  o.estimator = EstimatorKind::kWheels;
  auto odometry = make(array, o);
  Collected out;
  const Twist2 twist{{0.2, -0.1}, 0.5};
  ASSERT_FALSE(odometry->push_wheels(0.0, twist, out));
  for (int k = 1; k <= 100; ++k) {
    const double t = 0.02 * k;
    ASSERT_FALSE(odometry->push_wheels(t, twist, out));
    for (int i = 0; i < array.size(); ++i) {
      ASSERT_FALSE(odometry->push(SensorRow{t, i, {100.0, 0.0}, std::nullopt, 0}, out));
    }
  }
  odometry->finish(2.0, out);
  ASSERT_FALSE(out.steps.empty());
  const Pose2 expected = integrate_exact(Pose2{}, twist, out.steps.back().t());
  EXPECT_NEAR(out.steps.back().pose.t.x(), expected.t.x(), 1e-9);
  EXPECT_NEAR(out.steps.back().pose.t.y(), expected.t.y(), 1e-9);
  EXPECT_NEAR(out.steps.back().pose.theta, expected.theta, 1e-9);
  EXPECT_EQ(out.steps.back().estimate.source, Source::kWheels);
  EXPECT_EQ(out.steps.back().estimate.estimate.used, 0u);
}

TEST(Odometry, OracleLeavesOutTheSensorsTheSimulatorFlagged) {
  const SensorArray array = test::skewed_array();
  const auto log = test::synthesise(array, test::mixed_motion, 2.0, 0.01);
  OdometryOptions o;
  o.estimator = EstimatorKind::kOracle;
  auto odometry = make(array, o);
  Collected out;
  for (const auto& r : log.rows) {
    SensorRow row{r.t, r.sensor, r.counts, std::nullopt, 0};
    if (r.sensor == 1 && r.t > 1.0) {
      row.counts *= 0.3;  // a fault the simulator knows of
      row.faults = 1;
    }
    ASSERT_FALSE(odometry->push(row, out));
  }
  odometry->finish(log.rows.back().t, out);
  const auto& last = out.steps.back();
  EXPECT_EQ(last.estimate.excluded[1], Exclusion::kFaulty);
  EXPECT_EQ(last.estimate.estimate.used, 0b1101u);
  // The pose is as good as with sound sensors: within a few quantisation
  // steps of the truth at the end (noise-free rows, 2 s).
  const Pose2& truth = log.truth.back().pose;
  EXPECT_NEAR(last.pose.t.x(), truth.t.x(), 2e-4);
  EXPECT_NEAR(last.pose.t.y(), truth.t.y(), 2e-4);
}

TEST(Odometry, AnEpochWaitsForTheWheelRowThatCoversIt) {
  const SensorArray array = test::skewed_array();
  OdometryOptions o;
  o.estimator = EstimatorKind::kWheels;
  auto odometry = make(array, o);
  Collected out;
  ASSERT_FALSE(odometry->push_wheels(0.0, Twist2{{0.1, 0}, 0}, out));
  // Mice rows of every sensor up to 0.1 s make the epochs up to 0.1 s final
  // (at most kMaxWaitingEpochs wait), but the wheels have not reached them.
  for (int k = 1; k <= 10; ++k) {
    for (int i = 0; i < array.size(); ++i) {
      ASSERT_FALSE(odometry->push(SensorRow{0.01 * k, i, {0.0, 0.0}, std::nullopt, 0}, out));
    }
  }
  EXPECT_TRUE(out.steps.empty());
  ASSERT_FALSE(odometry->push_wheels(0.05, Twist2{{0.1, 0}, 0}, out));
  ASSERT_EQ(out.steps.size(), 5u);
  for (const auto& s : out.steps) EXPECT_NEAR(s.estimate.estimate.twist.v.x(), 0.1, 1e-12);
}

TEST(Odometry, MiceSilentWhileTheWheelsReportDoNotPileUpWheelRows) {
  // Ten seconds of wheel rows at 100 Hz (far more than the wheel ring holds)
  // and no mice row: the epochs no mice row can reach any more are final.
  const SensorArray array = test::skewed_array();
  OdometryOptions o;
  auto odometry = make(array, o);
  Collected out;
  for (int k = 0; k <= 1000; ++k) {
    ASSERT_FALSE(odometry->push_wheels(0.01 * k, Twist2{{0.1, 0}, 0}, out)) << k;
  }
  EXPECT_GT(out.steps.size(), 990u);
  // The mice saw no motion, so the consensus of four still sensors wins.
  EXPECT_EQ(out.steps.back().estimate.source, Source::kMice);
}

TEST(Odometry, RowsGoingBackwardsAreRefusedWithTheRowError) {
  OdometryOptions o;
  auto odometry = make(test::skewed_array(), o);
  Collected out;
  ASSERT_FALSE(odometry->push(SensorRow{0.5, 0, {1, 1}, std::nullopt, 0}, out));
  EXPECT_EQ(odometry->push(SensorRow{0.4, 1, {1, 1}, std::nullopt, 0}, out), OdometryError::kRow);
  EXPECT_EQ(odometry->row_error(), RowError::kTimeBackwards);
  EXPECT_EQ(odometry->push_wheels(std::nan(""), Twist2{}, out), OdometryError::kWheelsBackwards);
}

// Finite but absurd values of the other streams (1.7e308 m/s in wheels.csv
// made odometry.csv's sds inf and theta 1.8e306) and non-finite ones are
// refused as the mice's impossible counts are, and nothing is fed: the
// steps after them are those of a run without them (issue #47, item 5).
TEST(Odometry, ImplausibleWheelGyroAndCameraValuesAreRefusedAndNotFed) {
  OdometryOptions o;
  o.fuse_camera = true;
  auto odometry = make(test::skewed_array(), o);
  Collected out;
  const double nan = std::nan("");
  for (const Twist2& bad : {Twist2{{1.7e308, 0}, 0}, Twist2{{0, -101}, 0}, Twist2{{0, 0}, 1001},
                            Twist2{{nan, 0}, 0}, Twist2{{0, 0}, nan}}) {
    EXPECT_EQ(odometry->push_wheels(0.01, bad, out), OdometryError::kImplausibleWheels);
  }
  EXPECT_FALSE(odometry->push_wheels(0.01, Twist2{{100, -100}, 1000}, out));
  for (const double gz : {1e308, -1000.5, nan}) {
    EXPECT_EQ(odometry->push_gyro(0.01, gz, out), OdometryError::kImplausibleGyro) << gz;
  }
  EXPECT_FALSE(odometry->push_gyro(0.01, -1000.0, out));
  CameraFix fix{0.01, {1e300, 0}, std::nullopt, std::nullopt};
  EXPECT_EQ(odometry->push_fix(fix), OdometryError::kImplausibleFix);
  fix.position = {0, 0};
  fix.theta = 1e8;
  EXPECT_EQ(odometry->push_fix(fix), OdometryError::kImplausibleFix);
  fix.theta = 1.0;
  fix.sigma = Vec2{0.01, 1e7};
  EXPECT_EQ(odometry->push_fix(fix), OdometryError::kImplausibleFix);
  fix.sigma = Vec2{0.01, 0.0};
  EXPECT_EQ(odometry->push_fix(fix), OdometryError::kImplausibleFix);
  fix.sigma = Vec2{0.01, 0.02};
  EXPECT_FALSE(odometry->push_fix(fix));
  EXPECT_STREQ(describe(OdometryError::kImplausibleWheels),
               "wheel twist beyond the plausible (|vx|, |vy| <= 100 m/s, |omega| <= 1000 rad/s; "
               "a corrupt value?)");
}

}  // namespace
}  // namespace moa
