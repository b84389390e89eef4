// Page's CUSUM (core/cusum.hpp): its alarm level against the run lengths it
// promises, by simulation.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "moa/core/cusum.hpp"

namespace {

using moa::real;

// Samples of N(mu, 1) fed until the two-sided test alarms, over `runs`
// runs: the mean run length.
double mean_run_length(double mu, real k, real h, int runs, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> z(mu, 1.0);
  double total = 0.0;
  for (int r = 0; r < runs; ++r) {
    moa::TwoSidedCusum c;
    int n = 1;
    while (!c.feed(static_cast<real>(z(rng)), k, h)) ++n;
    total += n;
  }
  return total / runs;
}

TEST(Cusum, TheAlarmLevelGivesTheMeanRunLengthAskedFor) {
  // h for a one-sided mean run of 600 samples: the two sides together alarm
  // after about 300 (1 / ARL = 1 / ARL+ + 1 / ARL-). Run lengths are near
  // exponential (sd about the mean): over 400 runs the mean's standard
  // error is 5 %; 4 of them, and the approximation's few per cent, 25 %.
  const real k = 0.5, h = moa::cusum_threshold(k, 600);
  EXPECT_NEAR(mean_run_length(0.0, k, h, 400, 31), 300.0, 0.25 * 300.0);
}

TEST(Cusum, AShiftIsFoundWhenSiegmundSays) {
  // A shift of mu = 1.5 sd with k = 0.5 and the level of one false alarm in
  // 7.2e5 samples (the gyro's test at 100 Hz, an hour): the mean delay is
  // Siegmund's ARL(d) = (exp(-2 d h') + 2 d h' - 1) / (2 d^2), d = mu - k,
  // h' = h + 1.166, computed here apart from the code under test. The delay
  // varies little (sd about 2 samples): 400 runs give its mean to 1 %.
  const real k = 0.5, h = moa::cusum_threshold(k, 7.2e5);
  const double d = 1.0, hp = h + 1.166;
  const double expected = (std::exp(-2 * d * hp) + 2 * d * hp - 1) / (2 * d * d);
  EXPECT_NEAR(mean_run_length(1.5, k, h, 400, 32), expected, 0.1 * expected);
  // And the level itself: Siegmund's ARL(-k) at h' is 7.2e5.
  const double arl = (std::exp(2 * k * hp) - 2 * k * hp - 1) / (2 * k * k);
  EXPECT_NEAR(arl, 7.2e5, 1e-3 * 7.2e5);
}

}  // namespace
