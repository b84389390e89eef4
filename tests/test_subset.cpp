// SubsetSolver: a fit from prepared per-sensor terms is the fit that
// computes them itself, to the bit, for every subset of random samples; and
// twist() is fit()'s twist to the bit.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "moa/core/subset.hpp"

namespace moa {
namespace {

// Same bits, not merely equal (the odometry output must not change).
bool same_bits(real a, real b) { return std::memcmp(&a, &b, sizeof a) == 0; }

TEST(SubsetSolver, PreparedTermsGiveTheSameFitToTheBit) {
  std::mt19937_64 random(20261122);
  std::uniform_real_distribution<real> uniform(-1.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    const int n = 2 + trial % 7;
    std::vector<SensorMount> mounts(static_cast<std::size_t>(n));
    for (auto& m : mounts) m.position = 0.15 * Vec2(uniform(random), uniform(random));
    const SensorArray array(mounts);
    const SubsetSolver solver(array);
    PointMeasurements plain;
    plain.size = n;
    for (std::size_t i = 0; i < static_cast<std::size_t>(n); ++i) {
      plain.u[i] = Vec2(uniform(random), uniform(random));
      // S^-1 symmetric positive definite, (s/m)^2 of a few mm/s.
      const Vec2 d(std::exp(6.0 + 3.0 * uniform(random)), std::exp(6.0 + 3.0 * uniform(random)));
      const real c = 0.9 * uniform(random) * std::sqrt(d.x() * d.y());
      plain.info[i] << d.x(), c, c, d.y();
    }
    PointMeasurements prepared = plain;
    solver.prepare(prepared);
    ASSERT_EQ(prepared.prepared_by, &solver);
    for (SensorMask mask = 0; mask < (SensorMask{1} << n); ++mask) {
      const auto a = solver.fit(mask, plain);
      const auto b = solver.fit(mask, prepared);
      ASSERT_EQ(a.has_value(), b.has_value()) << mask;
      // twist(): fit()'s twist alone, to the bit, from either.
      for (const PointMeasurements* m : {&plain, &prepared}) {
        const auto t = solver.twist(mask, *m);
        ASSERT_EQ(t.has_value(), a.has_value()) << mask;
        for (int k = 0; t && k < 3; ++k) {
          const auto& f = m == &plain ? a : b;
          EXPECT_TRUE(same_bits(t->vector()(k), f->twist.vector()(k))) << mask;
        }
      }
      if (!a) continue;
      EXPECT_EQ(a->dof, b->dof);
      EXPECT_TRUE(same_bits(a->chi2, b->chi2)) << mask;
      for (int k = 0; k < 3; ++k) {
        EXPECT_TRUE(same_bits(a->twist.vector()(k), b->twist.vector()(k))) << mask;
        for (int j = 0; j < 3; ++j)
          EXPECT_TRUE(same_bits(a->covariance(k, j), b->covariance(k, j)));
      }
    }
  }
}

TEST(SubsetSolver, TermsOfAnotherSolverAreNotUsed) {
  const SensorArray a = regular_polygon(4, 0.1, 0.0);
  const SensorArray b = regular_polygon(4, 0.2, 0.3);
  const SubsetSolver sa(a), sb(b);
  PointMeasurements m;
  m.size = 4;
  for (std::size_t i = 0; i < 4; ++i) {
    m.u[i] = Vec2(0.1 * static_cast<real>(i), -0.05);
    m.info[i] = Mat2::Identity() * 1e4;
  }
  const auto own = sb.fit(all_sensors(4), m);
  sa.prepare(m);
  const auto after = sb.fit(all_sensors(4), m);
  ASSERT_TRUE(own && after);
  EXPECT_EQ(own->twist.vector(), after->twist.vector());
  EXPECT_EQ(own->chi2, after->chi2);
}

}  // namespace
}  // namespace moa
