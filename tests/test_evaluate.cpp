#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "moa/analysis/evaluate.hpp"
#include "moa/core/array.hpp"

namespace moa {
namespace {

TEST(Evaluate, InterpolatesLinearlyInsideAndRefusesOutside) {
  const std::vector<StampedPose> truth{{0.0, {{0.0, 0.0}, 0.0}}, {1.0, {{1.0, 2.0}, 3.0}}};
  const auto mid = interpolate(truth, 0.25);
  ASSERT_TRUE(mid.has_value());
  EXPECT_NEAR(mid->t.x(), 0.25, 1e-15);
  EXPECT_NEAR(mid->t.y(), 0.5, 1e-15);
  EXPECT_NEAR(mid->theta, 0.75, 1e-15);
  EXPECT_FALSE(interpolate(truth, -0.1).has_value());
  EXPECT_FALSE(interpolate(truth, 1.1).has_value());
  EXPECT_TRUE(interpolate(truth, 1.0).has_value());
}

TEST(Evaluate, MaxAndRmsAgainstHandComputation) {
  const std::vector<StampedPose> truth{{0.0, {}}, {10.0, {}}};
  TrajectoryErrorAccumulator acc(truth);
  acc.add(1.0, Pose2{{0.3, 0.4}, 0.1});                            // 0.5 m, 0.1 rad
  acc.add(2.0, Pose2{{0.0, 0.0}, -0.2});                           // 0 m, 0.2 rad
  acc.add(3.0, Pose2{{0.0, 0.0}, 2.0 * std::numbers::pi + 0.05});  // heading wraps: 0.05
  acc.add(11.0, Pose2{{9.0, 9.0}, 0.0});                           // outside the truth's span
  const TrajectoryError e = acc.result();
  EXPECT_EQ(e.samples, 3u);
  EXPECT_EQ(e.outside, 1u);
  EXPECT_NEAR(e.max_translation, 0.5, 1e-12);
  EXPECT_NEAR(e.rms_translation, std::sqrt(0.25 / 3.0), 1e-12);
  EXPECT_NEAR(e.max_heading, 0.2, 1e-12);
  EXPECT_NEAR(e.rms_heading, std::sqrt((0.01 + 0.04 + 0.0025) / 3.0), 1e-12);
}

TEST(Evaluate, PathLengthSumsSegmentsAndInterpolatesTheEnds) {
  // A 3-4-5 leg then a 5-12-13 leg: 5 m and 13 m by hand.
  const std::vector<StampedPose> path{
      {0.0, {{0.0, 0.0}, 0.0}}, {1.0, {{3.0, 4.0}, 0.0}}, {2.0, {{8.0, 16.0}, 0.0}}};
  EXPECT_NEAR(path_length(path, 0.0, 2.0), 18.0, 1e-12);
  EXPECT_NEAR(path_length(path, -5.0, 9.0), 18.0, 1e-12);  // clamped to the span
  EXPECT_NEAR(path_length(path, 0.5, 1.5), 2.5 + 6.5, 1e-12);
  EXPECT_NEAR(path_length(path, 0.2, 0.6), 0.4 * 5.0, 1e-12);  // inside one segment
  EXPECT_EQ(path_length(path, 1.5, 0.5), 0.0);
  EXPECT_EQ(path_length({}, 0.0, 1.0), 0.0);
}

TEST(Evaluate, PathLengthOfASampledCircleApproachesItsArc) {
  // Chords of a circle of radius r, n per turn: n 2 r sin(pi/n) in closed form.
  const double r = 0.7;
  const int n = 360;
  std::vector<StampedPose> circle;
  for (int i = 0; i <= n; ++i) {
    const double a = 2.0 * std::numbers::pi * i / n;
    circle.push_back({i * 0.01, {{r * std::cos(a), r * std::sin(a)}, a}});
  }
  EXPECT_NEAR(path_length(circle, 0.0, n * 0.01), n * 2.0 * r * std::sin(std::numbers::pi / n),
              1e-12);
}

TEST(Evaluate, DistanceRunsFromTheTruthsStartToTheLastEstimateCompared) {
  const std::vector<StampedPose> truth{{0.0, {}}, {10.0, {{10.0, 0.0}, 0.0}}};
  TrajectoryErrorAccumulator acc(truth);
  acc.add(2.0, Pose2{{2.0, 0.0}, 0.0});
  acc.add(6.0, Pose2{{6.0, 0.0}, 0.0});
  acc.add(12.0, Pose2{{6.0, 0.0}, 0.0});  // outside: does not extend the distance
  EXPECT_NEAR(acc.result().distance, 6.0, 1e-12);
}

std::vector<StampedPose> straight_path(double speed, double dt, int rows) {
  std::vector<StampedPose> path;
  for (int k = 0; k <= rows; ++k) path.push_back({k * dt, {{speed * k * dt, 0.0}, 0.0}});
  return path;
}

TEST(Evaluate, QuantisationFloorIsZeroWhenEveryRowHoldsWholeCounts) {
  // 400 cpi: 1 count = 63.5 um. 0.00635 m/s for 0.01 s is exactly one count per row
  // on every sensor of a polygon aligned with the robot.
  SensorMount proto;
  proto.cpi = 400.0;
  const SensorArray array = regular_polygon(4, 0.1, 0.0, proto);
  const auto floor = quantisation_floor(array, straight_path(0.00635, 0.01, 200));
  ASSERT_TRUE(floor.has_value());
  EXPECT_EQ(floor->samples, 200u);
  EXPECT_LT(floor->max_translation, 1e-12);
  EXPECT_LT(floor->max_heading, 1e-12);
}

TEST(Evaluate, QuantisationFloorOfATranslationIsWithinHalfACount) {
  // Pure translation, a polygon aligned with the robot: the least-squares twist
  // is the average of the points' velocities (Kim & Lee eq. (9)), and each
  // sensor's running total is off by at most half a count per axis, so the
  // position is off by at most half a count per axis, and by more than zero
  // because 0.3 count per row does not stay whole.
  SensorMount proto;
  proto.cpi = 400.0;
  const double count = kMetresPerInch / 400.0;
  const SensorArray array = regular_polygon(4, 0.1, 0.3, proto);
  const auto floor = quantisation_floor(array, straight_path(0.3 * count / 0.01, 0.01, 500));
  ASSERT_TRUE(floor.has_value());
  EXPECT_GT(floor->max_translation, 0.1 * count);
  EXPECT_LE(floor->max_translation, 0.5 * count + 1e-12);
  EXPECT_NEAR(floor->distance, 500 * 0.3 * count, 1e-12);
}

TEST(Evaluate, QuantisationFloorNeedsAGeometryAndIncreasingTimes) {
  SensorMount proto;
  const SensorArray one(1, proto);
  EXPECT_FALSE(quantisation_floor(one, straight_path(0.1, 0.01, 10)).has_value());
  const SensorArray array = regular_polygon(3, 0.1, 0.0, proto);
  EXPECT_FALSE(quantisation_floor(array, straight_path(0.1, 0.01, 0)).has_value());
  std::vector<StampedPose> repeated = straight_path(0.1, 0.01, 3);
  repeated[2].t = repeated[1].t;
  EXPECT_FALSE(quantisation_floor(array, repeated).has_value());
}

TEST(Evaluate, DescribesTheTranslationErrorInMillimetresOverTheDistance) {
  TrajectoryError e;
  e.max_translation = 0.0154;
  e.rms_translation = 0.00676;
  e.distance = 2.5;
  EXPECT_EQ(describe_translation(e), "max 15.4 mm over 2.5 m travelled (0.62 %), rms 6.76 mm");
  e.distance = 0.0;
  EXPECT_EQ(describe_translation(e), "max 15.4 mm over 0 m travelled, rms 6.76 mm");
  // Large numbers in plain notation, not 1.23e+03 mm nor 1.2e+02 %.
  e.max_translation = 1.234;
  e.distance = 1.0;
  EXPECT_EQ(describe_translation(e), "max 1234 mm over 1 m travelled (123 %), rms 6.76 mm");
}

TEST(Evaluate, VerdictFollowsTheRatioToTheReference) {
  TrajectoryError e;
  e.max_translation = 0.015;
  EXPECT_EQ(verdict(e, {0.020, "the paper"}), "within the paper's 20 mm (max 15 mm, 0.75x)");
  EXPECT_EQ(verdict(e, {0.010, "the paper"}), "above the paper's 10 mm (max 15 mm, 1.5x)");
  const ErrorReference floor{0.01, "the quantisation floor", true};
  EXPECT_EQ(verdict(e, floor).rfind("at the quantisation floor", 0), 0u) << verdict(e, floor);
  e.max_translation = 0.021;  // past kFloorTolerance = 2
  EXPECT_EQ(verdict(e, floor).rfind("2.1x the quantisation floor", 0), 0u) << verdict(e, floor);
}

}  // namespace
}  // namespace moa
