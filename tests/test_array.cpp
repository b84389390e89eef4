// SensorArray held in place (no heap), and the consensus estimator's subset
// search at the largest array it searches exhaustively.
#include <gtest/gtest.h>

#include <bit>
#include <variant>
#include <vector>

#include "moa/core/array.hpp"
#include "moa/core/consensus.hpp"
#include "moa/core/estimate.hpp"
#include "moa/core/sekimori.hpp"

namespace moa {
namespace {

TEST(SensorArray, HoldsTheMountsItIsGivenInOrder) {
  std::vector<SensorMount> given(3);
  for (std::size_t i = 0; i < given.size(); ++i) {
    given[i].position = {0.01 * static_cast<double>(i), -0.02};
    given[i].cpi = 400.0 * static_cast<double>(i + 1);
  }
  const SensorArray a(given);
  ASSERT_EQ(a.size(), 3);
  ASSERT_EQ(a.mounts().size(), 3u);
  for (int i = 0; i < a.size(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    EXPECT_EQ(a[i].position, given[k].position);
    EXPECT_EQ(a.mounts()[k].cpi, given[k].cpi);
  }
}

TEST(SensorMask, CountSensorsIsThePopulationCount) {
  for (std::uint32_t m = 0; m < (1u << 16); ++m) ASSERT_EQ(count_sensors(m), std::popcount(m)) << m;
  for (const std::uint32_t m : {0xFFFFFFFFu, 0x80000000u, 0xAAAAAAAAu, 0x12345678u, 0xFFFF0001u}) {
    EXPECT_EQ(count_sensors(m), std::popcount(m)) << m;
  }
}

TEST(SensorArray, MoreThanMaxSensorsIsRefusedByEveryEstimator) {
  const SensorArray a = regular_polygon(kMaxSensors + 1, 0.1, 0.0);
  EXPECT_EQ(a.size(), kMaxSensors + 1);
  const auto ls = LsEstimator::create(a, all_sensors(a.size()), 0.01);
  ASSERT_TRUE(std::holds_alternative<GeometryError>(ls));
  EXPECT_EQ(*std::get_if<GeometryError>(&ls), GeometryError::kTooManySensors);
  const auto consensus = ConsensusEstimator::create(a);
  ASSERT_TRUE(std::holds_alternative<GeometryError>(consensus));
  EXPECT_EQ(*std::get_if<GeometryError>(&consensus), GeometryError::kTooManySensors);
  const auto sekimori = SekimoriEstimator::create(a);
  ASSERT_TRUE(std::holds_alternative<GeometryError>(sekimori));
  EXPECT_EQ(*std::get_if<GeometryError>(&sekimori), GeometryError::kTooManySensors);
}

// At kMaxExhaustive sensors every subset is searched: two sensors that are
// far off (50 cm/s against a few mm/s of tolerance) are left out wherever
// they sit in the mask, and the other eight give the twist exactly.
class ConsensusAtMaxExhaustive : public testing::TestWithParam<std::pair<int, int>> {};

TEST_P(ConsensusAtMaxExhaustive, LeavesOutExactlyTheTwoBadSensors) {
  constexpr int n = ConsensusEstimator::kMaxExhaustive;
  constexpr double dt = 0.01;
  const SensorArray a = regular_polygon(n, 0.1, 0.3);
  const Twist2 truth{{0.2, -0.05}, 0.6};
  ArraySample s;
  s.t = dt;
  s.dt = dt;
  s.size = n;
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    s.counts[k] = a[i].counts(truth, dt);
    s.squal[k] = 255;
  }
  const auto [bad1, bad2] = GetParam();
  for (const int bad : {bad1, bad2}) {
    s.counts[static_cast<std::size_t>(bad)] +=
        a[bad].counts_from_robot_velocity() * Eigen::Vector2d(0.5, -0.3) * dt;
  }

  auto est = std::get<ConsensusEstimator>(ConsensusEstimator::create(a));
  const auto out = est.estimate(s);
  ASSERT_TRUE(out.has_value());
  EXPECT_EQ(out->source, Source::kMice);
  const SensorMask good = all_sensors(n) & ~(SensorMask{1} << bad1) & ~(SensorMask{1} << bad2);
  EXPECT_EQ(out->estimate.used, good);
  EXPECT_EQ(out->excluded[static_cast<std::size_t>(bad1)], Exclusion::kInconsistent);
  EXPECT_EQ(out->excluded[static_cast<std::size_t>(bad2)], Exclusion::kInconsistent);
  // Noise-free counts of eight sensors: the fit is the truth up to rounding.
  EXPECT_NEAR(out->estimate.twist.v.x(), truth.v.x(), 1e-9);
  EXPECT_NEAR(out->estimate.twist.v.y(), truth.v.y(), 1e-9);
  EXPECT_NEAR(out->estimate.twist.omega, truth.omega, 1e-9);
}

INSTANTIATE_TEST_SUITE_P(BadPairs, ConsensusAtMaxExhaustive,
                         testing::Values(std::pair{0, 1}, std::pair{8, 9}, std::pair{2, 7}));

}  // namespace
}  // namespace moa
