#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <limits>
#include <random>
#include <vector>

#include "moa/core/synchronise.hpp"

namespace moa {
namespace {

struct Collected {
  std::vector<ArraySample> samples;
  void operator()(const ArraySample& s) { samples.push_back(s); }
};

SensorRow row(double t, int sensor, double dx, double dy) {
  return SensorRow{t, sensor, {dx, dy}, std::nullopt, 0};
}

TEST(Synchroniser, RowsOnTheEpochGridAreUsedAsTheyAre) {
  Synchroniser sync(3, 0.0, {0.01, 0.05});
  Collected out;
  for (int k = 1; k <= 50; ++k) {
    for (int i = 0; i < 3; ++i) {
      ASSERT_FALSE(sync.push(row(k * 0.01, i, 10 * k + i, -k), std::ref(out)));
    }
  }
  sync.finish(0.5, std::ref(out));
  ASSERT_EQ(out.samples.size(), 50u);
  for (int k = 1; k <= 50; ++k) {
    const ArraySample& s = out.samples[static_cast<std::size_t>(k - 1)];
    EXPECT_NEAR(s.t, k * 0.01, 1e-12);
    EXPECT_NEAR(s.dt, 0.01, 1e-12);
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(s.counts[static_cast<std::size_t>(i)].x(), 10 * k + i, 1e-9) << k;
      EXPECT_NEAR(s.counts[static_cast<std::size_t>(i)].y(), -k, 1e-9);
    }
  }
}

TEST(Synchroniser, RowIsSpreadOverItsOwnIntervalByOverlap) {
  Synchroniser sync(2, 0.0, {0.01, 0.05});
  Collected out;
  ASSERT_FALSE(sync.push(row(0.025, 0, 100, 50), std::ref(out)));  // covers (0, 0.025]
  ASSERT_FALSE(sync.push(row(0.03, 1, 30, 0), std::ref(out)));     // covers (0, 0.03]
  sync.finish(0.03, std::ref(out));
  ASSERT_EQ(out.samples.size(), 3u);
  const double share[3] = {0.4, 0.4, 0.2};
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(out.samples[static_cast<std::size_t>(k)].counts[0].x(), 100 * share[k], 1e-9);
    EXPECT_NEAR(out.samples[static_cast<std::size_t>(k)].counts[0].y(), 50 * share[k], 1e-9);
    EXPECT_NEAR(out.samples[static_cast<std::size_t>(k)].counts[1].x(), 10, 1e-9);
  }
}

TEST(Synchroniser, CountsAreConservedAndEpochsAreContiguous) {
  std::mt19937_64 rng(20);
  std::uniform_real_distribution<double> gap(0.0, 0.03);
  std::uniform_int_distribution<int> counts(-50, 50), sensor(0, 3);
  Synchroniser sync(4, 1.0, {0.01, 0.05});
  Collected out;
  std::vector<Eigen::Vector2d> total(4, Eigen::Vector2d::Zero());
  double t = 1.0;
  for (int k = 0; k < 5000; ++k) {
    t += gap(rng);
    const int i = sensor(rng);
    const Eigen::Vector2d c(counts(rng), counts(rng));
    total[static_cast<std::size_t>(i)] += c;
    ASSERT_FALSE(sync.push(row(t, i, c.x(), c.y()), std::ref(out)));
  }
  sync.finish(t, std::ref(out));
  std::vector<Eigen::Vector2d> sum(4, Eigen::Vector2d::Zero());
  double expected_start = 1.0;
  for (const ArraySample& s : out.samples) {
    EXPECT_NEAR(s.t - s.dt, expected_start, 1e-9);
    expected_start = s.t;
    for (int i = 0; i < 4; ++i)
      sum[static_cast<std::size_t>(i)] += s.counts[static_cast<std::size_t>(i)];
  }
  EXPECT_NEAR(expected_start, t, 1e-12);
  for (int i = 0; i < 4; ++i) {
    EXPECT_TRUE(
        sum[static_cast<std::size_t>(i)].isApprox(total[static_cast<std::size_t>(i)], 1e-9));
  }
}

TEST(Synchroniser, GapMeansNoMotion) {
  // A mouse silent for a second, then one row: its counts fall into the last
  // max_row_interval before the row, every earlier epoch is still.
  Synchroniser sync(2, 0.0, {0.01, 0.05});
  Collected out;
  ASSERT_FALSE(sync.push(row(1.0, 0, 500, 0), std::ref(out)));
  ASSERT_FALSE(sync.push(row(1.0, 1, 500, 0), std::ref(out)));
  sync.finish(1.0, std::ref(out));
  ASSERT_EQ(out.samples.size(), 100u);
  for (std::size_t k = 0; k < 95; ++k) EXPECT_NEAR(out.samples[k].counts[0].x(), 0.0, 1e-9) << k;
  for (std::size_t k = 95; k < 100; ++k)
    EXPECT_NEAR(out.samples[k].counts[0].x(), 100.0, 1e-9) << k;
}

TEST(Synchroniser, FirstRowAtStartGoesIntoFirstEpoch) {
  Synchroniser sync(1, 2.0, {0.01, 0.05});
  Collected out;
  ASSERT_FALSE(sync.push(row(2.0, 0, 7, 3), std::ref(out)));
  ASSERT_FALSE(sync.push(row(2.02, 0, 2, 0), std::ref(out)));
  sync.finish(2.02, std::ref(out));
  ASSERT_EQ(out.samples.size(), 2u);
  EXPECT_NEAR(out.samples[0].counts[0].x(), 7 + 1, 1e-9);
  EXPECT_NEAR(out.samples[1].counts[0].x(), 1, 1e-9);
}

TEST(Synchroniser, SqualAndFlagsAreCarriedPerEpoch) {
  Synchroniser sync(2, 0.0, {0.01, 0.05});
  Collected out;
  SensorRow r = row(0.01, 0, 1, 1);
  r.squal = 40;
  r.flags = kFlagLift;
  ASSERT_FALSE(sync.push(r, std::ref(out)));
  r = row(0.02, 0, 1, 1);
  r.squal = 90;
  ASSERT_FALSE(sync.push(r, std::ref(out)));
  sync.finish(0.02, std::ref(out));
  ASSERT_EQ(out.samples.size(), 2u);
  EXPECT_EQ(out.samples[0].squal[0], 40);
  EXPECT_EQ(out.samples[0].flags[0], kFlagLift);
  EXPECT_EQ(out.samples[1].squal[0], 90);
  EXPECT_EQ(out.samples[1].flags[0], 0);
  EXPECT_EQ(out.samples[0].squal[1], 255);  // nothing reported
}

TEST(Synchroniser, InvalidRowsAreRejectedAndChangeNothing) {
  Synchroniser sync(2, 1.0, {0.01, 0.05});
  Collected out;
  ASSERT_FALSE(sync.push(row(1.5, 0, 1, 1), std::ref(out)));
  EXPECT_EQ(sync.push(row(1.4, 1, 1, 1), std::ref(out)), RowError::kTimeBackwards);
  EXPECT_EQ(sync.push(row(std::nan(""), 1, 1, 1), std::ref(out)), RowError::kTimeNotFinite);
  EXPECT_EQ(sync.push(row(1.6, 2, 1, 1), std::ref(out)), RowError::kUnknownSensor);
  EXPECT_EQ(sync.push(row(1.6, -1, 1, 1), std::ref(out)), RowError::kUnknownSensor);
  EXPECT_EQ(sync.push(row(1.6, 1, std::nan(""), 1), std::ref(out)), RowError::kCountsNotFinite);
  Synchroniser late(1, 1.0, {0.01, 0.05});
  EXPECT_EQ(late.push(row(0.5, 0, 1, 1), std::ref(out)), RowError::kTimeBeforeStart);
  EXPECT_STREQ(describe(RowError::kTimeBackwards), "time goes backwards");
}

TEST(Synchroniser, SilenceLongerThanMaxGapIsRefusedAndChangesNothing) {
  SynchroniserOptions options{0.01, 0.05, 2.0};
  Synchroniser sync(1, 0.0, options);
  Collected out;
  ASSERT_FALSE(sync.push(row(0.01, 0, 1, 0), std::ref(out)));
  const std::size_t before = out.samples.size();
  EXPECT_EQ(sync.push(row(2.02, 0, 1, 0), std::ref(out)), RowError::kTimeJump);
  EXPECT_EQ(out.samples.size(), before);                       // the refused row emitted nothing
  ASSERT_FALSE(sync.push(row(2.01, 0, 1, 0), std::ref(out)));  // exactly max_gap later
  sync.finish(2.01, std::ref(out));
  EXPECT_EQ(out.samples.size(), 201u);
}

// The silences summed (the time between rows beyond max_row_interval) may
// reach max_gap plus one period per row accepted: with max_gap 10 s, two
// gaps of 6 s cannot both pass, while one row in between them earns 0.01 s.
TEST(Synchroniser, SilencesSummedBeyondMaxGapPlusAnEpochPerRowAreRefused) {
  SynchroniserOptions options{0.01, 0.05, 10.0};
  Synchroniser sync(1, 0.0, options);
  Collected out;
  ASSERT_FALSE(sync.push(row(0.0, 0, 0, 0), std::ref(out)));
  ASSERT_FALSE(sync.push(row(6.0, 0, 0, 0), std::ref(out)));
  EXPECT_NEAR(sync.silence(), 5.95, 1e-12);
  EXPECT_EQ(sync.rows(), 2);
  EXPECT_DOUBLE_EQ(sync.silence_allowed(), 10.02);
  const std::size_t before = out.samples.size();
  EXPECT_EQ(sync.push(row(12.0, 0, 0, 0), std::ref(out)), RowError::kTooMuchSilence);
  EXPECT_EQ(out.samples.size(), before);  // the refused row emitted nothing
  EXPECT_NEAR(sync.silence(), 5.95, 1e-12);
  EXPECT_EQ(sync.rows(), 2);
  // A row within max_row_interval of the last adds no silence; one 4.06 s
  // later (4.01 s of silence) reaches 9.96 s of the 10.03 s allowed.
  ASSERT_FALSE(sync.push(row(6.05, 0, 0, 0), std::ref(out)));
  ASSERT_FALSE(sync.push(row(10.11, 0, 0, 0), std::ref(out)));
  EXPECT_NEAR(sync.silence(), 9.96, 1e-9);
  // Without a max_gap (live devices) there is no bound.
  Synchroniser live(1, 0.0, {0.01, 0.05, std::numeric_limits<double>::infinity()});
  for (int k = 0; k < 10; ++k) ASSERT_FALSE(live.push(row(k * 3600.0, 0, 0, 0), [](auto&) {}));
  EXPECT_STREQ(describe(RowError::kTooMuchSilence),
               "the sensors' silences add up to more than --max-gap plus one epoch per row: "
               "sparse rows would write an epoch per period over every gap (raise --max-gap if "
               "the log is meant so)");
}

TEST(Synchroniser, LatentRowsGiveTheEpochsOfTheirTrueTimes) {
  // Each sensor's rows stamped latency_i after the true end of their
  // interval, fed in the order of their stamps, must give the epochs that
  // the same rows at their true times give a synchroniser without latency.
  const std::array<double, 4> latency{0.002, 0.0071, -0.003, 0.012};
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> gap(0.001, 0.02);
  std::uniform_int_distribution<int> counts(-40, 40);
  struct Timed {
    double t_true;
    SensorRow row;
  };
  std::vector<Timed> rows;
  for (int i = 0; i < 4; ++i) {
    for (double t = 1.02 + gap(rng); t < 4.0; t += gap(rng)) {
      rows.push_back(
          {t, row(t + latency[static_cast<std::size_t>(i)], i, counts(rng), counts(rng))});
    }
  }
  SynchroniserOptions shifted{0.01, 0.05};
  std::copy(latency.begin(), latency.end(), shifted.latency.begin());
  Synchroniser late(4, 1.0, shifted), plain(4, 1.0, {0.01, 0.05});
  Collected from_late, from_plain;
  std::stable_sort(rows.begin(), rows.end(),
                   [](const Timed& a, const Timed& b) { return a.row.t < b.row.t; });
  for (const Timed& r : rows) ASSERT_FALSE(late.push(r.row, std::ref(from_late)));
  std::stable_sort(rows.begin(), rows.end(),
                   [](const Timed& a, const Timed& b) { return a.t_true < b.t_true; });
  double t_end = 0.0;
  for (const Timed& r : rows) {
    SensorRow at_truth = r.row;
    at_truth.t = r.t_true;
    ASSERT_FALSE(plain.push(at_truth, std::ref(from_plain)));
    t_end = r.t_true;
  }
  late.finish(t_end, std::ref(from_late));
  plain.finish(t_end, std::ref(from_plain));
  ASSERT_EQ(from_late.samples.size(), from_plain.samples.size());
  for (std::size_t k = 0; k < from_plain.samples.size(); ++k) {
    EXPECT_NEAR(from_late.samples[k].t, from_plain.samples[k].t, 1e-12);
    for (std::size_t i = 0; i < 4; ++i) {
      // Stamp minus latency differs from the true time by rounding only.
      EXPECT_LT((from_late.samples[k].counts[i] - from_plain.samples[k].counts[i]).norm(), 1e-6)
          << "epoch " << k << " sensor " << i;
    }
  }
}

TEST(Synchroniser, LatenciesSpreadBeyondThePendingEpochsAreRefused) {
  SynchroniserOptions o{0.01, 0.05};
  o.latency[0] = 0.3;
  o.latency[1] = -0.3;  // 0.05 + 0.6 s > 61 epochs of 10 ms
  EXPECT_TRUE(o.validate());
  o.latency[1] = -0.2;  // 0.55 s
  EXPECT_FALSE(o.validate());
  o.latency[2] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(o.validate());
}

}  // namespace
}  // namespace moa
