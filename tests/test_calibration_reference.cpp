// The reference side of a calibration: wheels rows merged into intervals,
// and the plausibility checks of a result.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <vector>

#include "moa/calibration/reference.hpp"

namespace moa {
namespace {

using ::testing::HasSubstr;

TEST(ReferenceIntervals, MergesRowsIntoDurationWeightedMeansOfAtLeastMinInterval) {
  // Rows every 10 ms (one repeated), merged into >= 30 ms: (0, 0.03] and
  // (0.03, 0.06]; the last row (0.07) is a tail shorter than 30 ms.
  const std::vector<double> t{0.0, 0.01, 0.02, 0.02, 0.03, 0.04, 0.05, 0.06, 0.07};
  std::vector<Twist2> twist;
  for (std::size_t k = 0; k < t.size(); ++k) {
    twist.push_back(Twist2{{0.1 * static_cast<double>(k), -0.2}, static_cast<double>(k)});
  }
  const ReferenceIntervals r = reference_intervals(t, twist, 0.03);
  EXPECT_EQ(r.repeated_rows, 1u);
  ASSERT_EQ(r.times.size(), 3u);
  ASSERT_EQ(r.twists.size(), 2u);
  EXPECT_DOUBLE_EQ(r.times[1], 0.03);
  EXPECT_DOUBLE_EQ(r.times[2], 0.06);
  // By hand: rows 1, 2, 4 (10 ms each) then rows 5, 6, 7; row 3 repeats t = 0.02.
  EXPECT_NEAR(r.twists[0].omega, (1.0 + 2.0 + 4.0) / 3.0, 1e-12);
  EXPECT_NEAR(r.twists[0].v.x(), 0.1 * (1.0 + 2.0 + 4.0) / 3.0, 1e-12);
  EXPECT_NEAR(r.twists[1].omega, (5.0 + 6.0 + 7.0) / 3.0, 1e-12);
  EXPECT_NEAR(r.twists[1].v.y(), -0.2, 1e-12);
}

TEST(ReferenceIntervals, ZeroMinIntervalKeepsEveryRow) {
  const std::vector<double> t{1.0, 1.5, 2.5};
  const std::vector<Twist2> twist{Twist2{}, Twist2{{1, 0}, 0}, Twist2{{0, 1}, 2}};
  const ReferenceIntervals r = reference_intervals(t, twist, 0.0);
  EXPECT_EQ(r.times, t);
  ASSERT_EQ(r.twists.size(), 2u);
  EXPECT_EQ(r.twists[1].omega, 2.0);
}

TEST(PlausibilityWarnings, NameTheSensorAndWhatIsImplausible) {
  SensorMount nominal;
  nominal.position = {0.1, 0.0};
  EXPECT_TRUE(plausibility_warnings("m1", nominal, nominal).empty());
  SensorMount moved = nominal;
  moved.position.x() += 0.03;
  moved.scale.y() = 1.3;
  moved.mirrored = true;
  const auto w = plausibility_warnings("m1", nominal, moved);
  ASSERT_EQ(w.size(), 3u);
  EXPECT_THAT(w[0], HasSubstr("m1: calibrated position is 30.0 mm from nominal"));
  EXPECT_THAT(w[1], HasSubstr("m1: scale differs from nominal by 30 %"));
  EXPECT_THAT(w[2], HasSubstr("m1: mirrored in the data but not in the nominal config"));
}

}  // namespace
}  // namespace moa
