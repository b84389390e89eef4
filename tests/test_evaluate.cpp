#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "moa/analysis/evaluate.hpp"

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

}  // namespace
}  // namespace moa
