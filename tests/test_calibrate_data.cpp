// The calibration vocabulary: pairing mice rows with reference intervals,
// merging samples, and splitting a sensor matrix into its parts.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "moa/calibration/calibrate.hpp"
#include "support/checks.hpp"

namespace moa {
namespace {

SensorRow row(double t, int sensor, double dx, double dy, std::uint8_t flags = 0) {
  return SensorRow{t, sensor, {dx, dy}, std::nullopt, flags};
}

TEST(IntervalAccumulator, SpreadsRowsOverIntervalsInProportionToOverlap) {
  // Reference intervals (0, 0.02], (0.02, 0.04], (0.04, 0.06]; sensor 0
  // reports (0, 0.03] and (0.03, 0.06], 30 counts each: by hand, 20, 10 + 10
  // and 20. Sensor 1 reports once per interval, exactly on the grid.
  IntervalAccumulator acc(2, 0.0, {0.0, 0.02, 0.04, 0.06}, 0.05);
  for (const SensorRow& r :
       {row(0.0, 0, 0, 0), row(0.0, 1, 0, 0), row(0.02, 1, 5, -1), row(0.03, 0, 30, 3),
        row(0.04, 1, 6, -2), row(0.06, 0, 30, 0), row(0.06, 1, 7, -3)}) {
    ASSERT_FALSE(acc.add(r));
  }
  const auto iv = acc.covered();
  ASSERT_EQ(iv.size(), 3u);
  const std::array<Eigen::Vector2d, 3> s0{Eigen::Vector2d(20, 2), Eigen::Vector2d(20, 1),
                                          Eigen::Vector2d(20, 0)};
  const std::array<Eigen::Vector2d, 3> s1{Eigen::Vector2d(5, -1), Eigen::Vector2d(6, -2),
                                          Eigen::Vector2d(7, -3)};
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(iv[k].index, static_cast<int>(k));
    EXPECT_NEAR(iv[k].sample.dt, 0.02, 1e-15);
    EXPECT_NEAR((iv[k].sample.counts[0] - s0[k]).norm(), 0.0, 1e-12) << k;
    EXPECT_NEAR((iv[k].sample.counts[1] - s1[k]).norm(), 0.0, 1e-12) << k;
  }
}

TEST(IntervalAccumulator, OnlyIntervalsWithinTheRowsSpanAreCovered) {
  // Rows from t0 = 0.1 to 0.25: of (0, 0.1], (0.1, 0.2], (0.2, 0.3] only the
  // middle one lies within.
  IntervalAccumulator acc(1, 0.1, {0.0, 0.1, 0.2, 0.3}, 0.05);
  ASSERT_FALSE(acc.add(row(0.1, 0, 0, 0)));
  ASSERT_FALSE(acc.add(row(0.15, 0, 4, 0)));
  ASSERT_FALSE(acc.add(row(0.25, 0, 4, 0)));
  const auto iv = acc.covered();
  ASSERT_EQ(iv.size(), 1u);
  EXPECT_EQ(iv[0].index, 1);
  // The row at 0.25 follows a 0.1 s gap, longer than max_row_interval: it
  // covers (0.2, 0.25] only (a gap means no motion), so interval 1 holds the
  // row at 0.15 alone.
  EXPECT_NEAR(iv[0].sample.counts[0].x(), 4.0, 1e-12);
}

TEST(IntervalAccumulator, FlagsAreCarriedAndBadRowsRejected) {
  IntervalAccumulator acc(1, 0.0, {0.0, 0.01, 0.02}, 0.05);
  ASSERT_FALSE(acc.add(row(0.01, 0, 1, 1, kFlagLift)));
  ASSERT_FALSE(acc.add(row(0.02, 0, 1, 1)));
  EXPECT_EQ(acc.covered()[0].sample.flags[0], kFlagLift);
  EXPECT_EQ(acc.covered()[1].sample.flags[0], 0);
  EXPECT_EQ(acc.add(row(0.015, 0, 1, 1)), RowError::kTimeBackwards);
  EXPECT_EQ(acc.add(row(0.03, 1, 1, 1)), RowError::kUnknownSensor);
  EXPECT_EQ(acc.add(row(-1.0, 0, 1, 1)), RowError::kTimeBeforeStart);
  EXPECT_EQ(acc.add(row(std::nan(""), 0, 1, 1)), RowError::kTimeNotFinite);
}

TEST(MergeSamples, SumsCountsAndAveragesTwistsOverEqualDurations) {
  std::vector<CalibrationSample> s(6);
  for (int k = 0; k < 6; ++k) {
    auto& x = s[static_cast<std::size_t>(k)];
    x.mice.size = 1;
    x.mice.t = 0.1 * (k + 1);
    x.mice.dt = 0.1;
    x.mice.counts[0] = {static_cast<double>(k), 1.0};
    x.reference = {{0.1 * k, 0.0}, static_cast<double>(k)};
  }
  const auto m = merge_samples(s, 3);
  ASSERT_EQ(m.size(), 3u);
  for (int g = 0; g < 3; ++g) {
    const auto& x = m[static_cast<std::size_t>(g)];
    EXPECT_NEAR(x.mice.dt, 0.2, 1e-12);
    EXPECT_NEAR(x.mice.t, 0.1 * (2 * g + 2), 1e-12);
    EXPECT_NEAR(x.mice.counts[0].x(), 2.0 * g + 2 * g + 1, 1e-12);
    EXPECT_NEAR(x.mice.counts[0].y(), 2.0, 1e-12);
    EXPECT_NEAR(x.reference.omega, 2.0 * g + 0.5, 1e-12);
  }
  EXPECT_EQ(merge_samples(s, 0).size(), 6u);
  EXPECT_EQ(merge_samples(s, 10).size(), 6u);
}

TEST(DecomposeSensorMatrix, RecoversYawScaleAndMirroringOfRandomMounts) {
  std::mt19937_64 rng(41);
  for (int trial = 0; trial < 200; ++trial) {
    const SensorMount m = test::random_mount(rng);
    const auto parts =
        decompose_sensor_matrix(m.counts_from_robot_velocity(), m.counts_per_metre());
    ASSERT_TRUE(parts);
    EXPECT_NEAR(wrap_angle(parts->yaw - m.yaw), 0.0, 1e-12) << trial;
    EXPECT_NEAR((parts->scale - m.scale).norm(), 0.0, 1e-12) << trial;
    EXPECT_EQ(parts->mirrored, m.mirrored) << trial;
    // q = M J p gives p back.
    const Eigen::Matrix2d g = m.counts_from_robot_velocity();
    EXPECT_NEAR(
        (position_from_rotation_response(g, g * skew_unit() * m.position) - m.position).norm(), 0.0,
        1e-12);
  }
  EXPECT_FALSE(decompose_sensor_matrix(Eigen::Matrix2d::Zero(), 31496.0));
}

}  // namespace
}  // namespace moa
