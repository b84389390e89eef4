// Speed-dependent resolution (core/speed_scale.hpp): the table, its
// inversion against a bisection written here, the forward model then the
// inverse, the pipeline's correction, and the calibration's fit of the
// table (calibration/speed_scale.hpp) against tables it was not given.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "moa/calibration/speed_scale.hpp"
#include "moa/core/odometry.hpp"
#include "moa/core/speed_scale.hpp"
#include "support/synth.hpp"

namespace moa {
namespace {

SpeedScale table(std::vector<double> speeds, std::vector<double> ratios) {
  return SpeedScale(speeds.data(), ratios.data(), static_cast<int>(speeds.size()),
                    static_cast<int>(ratios.size()));
}

// The table's ratio written out independently: linear between the knots,
// constant beyond the ends.
double reference_ratio(const std::vector<double>& s, const std::vector<double>& r, double v) {
  if (v <= s.front()) return r.front();
  if (v >= s.back()) return r.back();
  for (std::size_t k = 0; k + 1 < s.size(); ++k) {
    if (v <= s[k + 1]) return r[k] + (r[k + 1] - r[k]) * (v - s[k]) / (s[k + 1] - s[k]);
  }
  return r.back();
}

// The true speed with s ratio(s) = c by bisection on [0, c / min ratio].
double bisect(const std::vector<double>& s, const std::vector<double>& r, double c) {
  double lo = 0.0, hi = c / 0.5 + 1.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (mid * reference_ratio(s, r, mid) < c ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// A random usable table: 2..8 knots from 0..0.6 m/s, ratios in [0.8, 1.2].
void random_table(std::mt19937_64& rng, std::vector<double>& s, std::vector<double>& r) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  do {
    const int n = 2 + static_cast<int>(rng() % 7);
    s.assign(1, 0.6 * u(rng));
    r.assign(1, 0.8 + 0.4 * u(rng));
    for (int k = 1; k < n; ++k) {
      s.push_back(s.back() + 0.05 + 0.8 * u(rng));
      r.push_back(0.8 + 0.4 * u(rng));
    }
  } while (!table(s, r).active());
}

TEST(SpeedScale, IdentityWithoutATable) {
  const SpeedScale none;
  EXPECT_FALSE(none.active());
  EXPECT_EQ(none.ratio(2.0), 1.0);
  EXPECT_EQ(none.correction(2.0), 1.0);
  const SensorMount m;
  const Vec2 counts(1234.5, -77.0);
  EXPECT_EQ(corrected_counts(m.speed_scale, m.robot_velocity_from_counts(), counts, 0.01), counts);
}

TEST(SpeedScale, RatioIsPiecewiseLinearAndConstantBeyondTheEnds) {
  const SpeedScale t = table({0.5, 1.5, 2.5}, {1.0, 0.96, 0.9});
  ASSERT_TRUE(t.active());
  EXPECT_EQ(t.ratio(0.0), 1.0);
  EXPECT_EQ(t.ratio(0.5), 1.0);
  EXPECT_NEAR(t.ratio(1.0), 0.98, 1e-15);
  EXPECT_NEAR(t.ratio(1.5), 0.96, 1e-15);
  EXPECT_NEAR(t.ratio(2.0), 0.93, 1e-15);
  EXPECT_EQ(t.ratio(2.5), 0.9);
  EXPECT_EQ(t.ratio(10.0), 0.9);
}

TEST(SpeedScale, InversionAgreesWithBisection) {
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 300; ++trial) {
    std::vector<double> s, r;
    random_table(rng, s, r);
    const SpeedScale t = table(s, r);
    for (int j = 0; j < 20; ++j) {
      // Counted speeds below, inside and beyond the knots, and at a knot's image.
      const double c = j == 0 ? s[1] * r[1] : 1.2 * (s.back() + 0.5) * u(rng);
      const double expected = bisect(s, r, c);
      EXPECT_NEAR(t.true_speed(c), expected, 1e-12 * (1.0 + expected)) << trial << " " << c;
      EXPECT_NEAR(t.correction(c), 1.0 / reference_ratio(s, r, expected), 1e-12);
    }
  }
}

TEST(SpeedScale, ForwardThenInverseIsTheIdentity) {
  std::mt19937_64 rng(32);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<double> s, r;
    random_table(rng, s, r);
    SensorMount m;
    m.position = {0.1 * u(rng), 0.1 * u(rng)};
    m.yaw = 3.0 * u(rng);
    m.cpi = 1600;
    m.scale = {1.0 + 0.05 * u(rng), 1.0 + 0.05 * u(rng)};
    m.mirrored = u(rng) > 0;
    m.speed_scale = table(s, r);
    const Twist2 x{{2.0 * u(rng), 2.0 * u(rng)}, 3.0 * u(rng)};
    const double dt = 0.01;
    // Forward: the sensor counts ratio(s) of the true counts, s its point's speed.
    const Vec2 truth = m.counts(x, dt);
    const double speed = (m.point_jacobian() * x.vector()).norm();
    const Vec2 counted = truth * reference_ratio(s, r, speed);
    const Vec2 back = corrected_counts(m.speed_scale, m.robot_velocity_from_counts(), counted, dt);
    EXPECT_LT((back - truth).norm(), 1e-10 * truth.norm() + 1e-12) << trial;
    EXPECT_NEAR(m.speed_scale.true_speed(speed * reference_ratio(s, r, speed)), speed,
                1e-12 * (1.0 + speed));
  }
}

TEST(SpeedScale, RefusesTablesItCannotUse) {
  using E = SpeedScale::Error;
  EXPECT_EQ(table({1.0}, {1.0}).error(), E::kTooFewKnots);
  EXPECT_EQ(table(std::vector<double>(9, 1.0), std::vector<double>(9, 1.0)).error(),
            E::kTooManyKnots);
  EXPECT_EQ(table({0.0, 1.0}, {1.0, 1.0, 1.0}).error(), E::kSizeMismatch);
  EXPECT_EQ(table({-0.1, 1.0}, {1.0, 1.0}).error(), E::kSpeedNotFinite);
  EXPECT_EQ(table({0.0, NAN}, {1.0, 1.0}).error(), E::kSpeedNotFinite);
  EXPECT_EQ(table({0.0, 1.0, 1.0}, {1.0, 1.0, 1.0}).error(), E::kSpeedsNotIncreasing);
  EXPECT_EQ(table({0.0, 1.0}, {1.0, 0.49}).error(), E::kRatioOutOfRange);
  EXPECT_EQ(table({0.0, 1.0}, {1.51, 1.0}).error(), E::kRatioOutOfRange);
  // s ratio(s) on [1, 2] with ratio 1 -> 0.5: f'(2) = 0.5 - 0.5 * 2 < 0.
  const SpeedScale falling = table({1.0, 2.0}, {1.0, 0.5});
  EXPECT_EQ(falling.error(), E::kNotMonotone);
  EXPECT_EQ(falling.error_knot(), 1);
  EXPECT_FALSE(falling.active());
  // The steepest fall still invertible: f'(2) = r(2) + m 2 > 0 with m = r(2) - 1.
  EXPECT_FALSE(table({1.0, 2.0}, {1.0, 0.67}).error());
  // A refused table makes the mount invalid for every estimator.
  SensorArray array = test::skewed_array();
  array[0].speed_scale = falling;
  const Odometry odometry(array, 0.0, OdometryOptions{});
  EXPECT_EQ(odometry.geometry_error(), GeometryError::kInvalidMount);
}

// Rows of a constant twist, counted by sensors with (or without) tables.
std::vector<SensorRow> rows_of(const SensorArray& truth, const Twist2& x, double seconds) {
  std::vector<SensorRow> rows;
  const double dt = 0.01;
  for (int k = 0; k <= static_cast<int>(seconds / dt); ++k) {
    for (int i = 0; i < truth.size(); ++i) {
      const SensorMount& m = truth[i];
      const double speed = (m.point_jacobian() * x.vector()).norm();
      const Vec2 c = k == 0 ? Vec2::Zero() : Vec2(m.counts(x, dt) * m.speed_scale.ratio(speed));
      rows.push_back(SensorRow{k * dt, i, c, std::nullopt, 0});
    }
  }
  return rows;
}

TEST(SpeedScale, ThePipelineUndoesEachSensorsTable) {
  SensorArray truth = test::skewed_array();
  truth[0].speed_scale = table({0.25, 1.0, 2.0}, {1.0, 0.97, 0.9});
  truth[1].speed_scale = table({0.5, 2.0}, {1.0, 0.94});
  const Twist2 x{{1.5, 0.4}, 0.9};
  const auto rows = rows_of(truth, x, 1.0);
  SensorArray plain = truth;
  for (int i = 0; i < plain.size(); ++i) plain[i].speed_scale = SpeedScale{};
  for (const bool with_table : {true, false}) {
    OdometryOptions o;
    o.estimator = EstimatorKind::kLs;
    Odometry odometry(with_table ? truth : plain, 0.0, o);
    ASSERT_FALSE(odometry.geometry_error());
    double worst = 0.0;
    std::size_t steps = 0;
    const auto sink = [&](const OdometryStep& s) {
      ++steps;
      worst = std::max(worst, (s.estimate.estimate.twist.vector() - x.vector()).norm());
    };
    for (const auto& row : rows) ASSERT_FALSE(odometry.push(row, sink));
    odometry.finish(rows.back().t, sink);
    ASSERT_GT(steps, 50u);
    if (with_table) {
      EXPECT_LT(worst, 1e-9) << "the tables undone, the counts are the model's";
    } else {
      EXPECT_GT(worst, 0.02) << "without them, the twist is off by percent";
    }
  }
}

// ---------------------------------------------------------------- the fit

// Four 1600 cpi sensors at the corners of a square of radius 0.1 m.
SensorArray square_array() {
  SensorMount proto;
  proto.cpi = 1600;
  return regular_polygon(4, 0.1, 0.3, proto);
}

// Reference windows of 50 ms with speeds spread over 0..2.3 m/s; counts
// through `truth`'s tables, with white noise of `noise` counts per axis.
std::vector<CalibrationSample> windows(const SensorArray& truth, int n, double noise,
                                       std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<CalibrationSample> out;
  const double dt = 0.05;
  for (int w = 0; w < n; ++w) {
    const double speed = 2.3 * (w + 0.5) / n;
    const double heading = 3.14159 * u(rng);
    const Twist2 x{{speed * std::cos(heading), speed * std::sin(heading)}, 1.5 * u(rng)};
    CalibrationSample s;
    s.reference = x;
    s.mice.t = dt * (w + 1);
    s.mice.dt = dt;
    s.mice.size = truth.size();
    for (int i = 0; i < truth.size(); ++i) {
      const SensorMount& m = truth[i];
      const double v = (m.point_jacobian() * x.vector()).norm();
      s.mice.counts[static_cast<std::size_t>(i)] =
          m.counts(x, dt) * m.speed_scale.ratio(v) + noise * Vec2(g(rng), g(rng));
    }
    out.push_back(s);
  }
  return out;
}

TEST(SpeedScaleFit, RecoversTheTablesWithinTheirSigma) {
  SensorArray truth = square_array();
  truth[0].speed_scale = table({0.25, 1.0, 2.0}, {1.0, 0.97, 0.9});
  truth[1].speed_scale = table({0.25, 1.0, 2.0}, {1.0, 0.99, 0.95});
  SpeedScaleOptions o;
  o.knots = {0.25, 1.0, 2.0};
  std::vector<double> z;  // (fit - truth) / sigma over seeds and knots
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    const auto fitted = fit_speed_scales(truth, windows(truth, 600, 2.0, seed), o);
    ASSERT_TRUE(std::holds_alternative<std::vector<SpeedScaleFit>>(fitted));
    const auto& fits = std::get<std::vector<SpeedScaleFit>>(fitted);
    ASSERT_EQ(fits.size(), 4u);
    for (int i = 0; i < 4; ++i) {
      const auto& f = fits[static_cast<std::size_t>(i)];
      EXPECT_EQ(f.ratios[0], 1.0);
      EXPECT_EQ(f.sigma[0], 0.0);
      for (std::size_t k = 1; k < 3; ++k) {
        const double expected =
            truth[i].speed_scale.ratio(o.knots[k]) / truth[i].speed_scale.ratio(o.knots[0]);
        ASSERT_GT(f.sigma[k], 0.0);
        EXPECT_LT(f.sigma[k], 2e-3);
        z.push_back((f.ratios[k] - expected) / f.sigma[k]);
      }
    }
  }
  // 80 standardised errors: mean within 4 / sqrt(80) of 0; rms within
  // 0.58..1.47, a little wider than chi-square(80)'s 1e-6 quantiles for
  // independent errors (0.65..1.39, Wilson-Hilferty): a sensor's two knots
  // share windows, so their errors are correlated.
  double mean = 0.0, sq = 0.0;
  for (const double v : z) {
    mean += v / static_cast<double>(z.size());
    sq += v * v / static_cast<double>(z.size());
  }
  EXPECT_LT(std::abs(mean), 4.0 / std::sqrt(static_cast<double>(z.size())));
  EXPECT_GT(std::sqrt(sq), 0.58);
  EXPECT_LT(std::sqrt(sq), 1.47);
}

TEST(SpeedScaleFit, RefusesAKnotTheDataDoNotReach) {
  SensorArray truth = square_array();
  SpeedScaleOptions o;
  o.knots = {0.25, 1.0, 4.0};
  const auto fitted = fit_speed_scales(truth, windows(truth, 600, 2.0, 1), o);
  ASSERT_TRUE(std::holds_alternative<SpeedScaleError>(fitted));
  const SpeedScaleError& e = std::get<SpeedScaleError>(fitted);
  EXPECT_EQ(e.kind, SpeedScaleError::Kind::kNotCovered);
  EXPECT_EQ(e.knot, 2);
  EXPECT_EQ(e.knot_speed, 4.0);
  EXPECT_LT(e.coverage, o.min_windows);
  const std::vector<std::string> names{"m1", "m2", "m3", "m4"};
  EXPECT_EQ(e.message(names).rfind("sensor 'm1': knot 4 m/s not covered by the data: ", 0), 0u)
      << e.message(names);
}

TEST(SpeedScaleFit, AlternatedWithTheMountsRecoversBoth) {
  SensorArray truth = square_array();
  for (int i = 0; i < 4; ++i) truth[i].yaw = 0.1 * i;
  truth[0].speed_scale = table({0.25, 1.0, 2.0}, {1.0, 0.97, 0.9});
  truth[2].speed_scale = table({0.25, 1.0, 2.0}, {1.0, 0.98, 0.93});
  SensorArray nominal = truth;
  for (int i = 0; i < 4; ++i) {
    nominal[i].speed_scale = SpeedScale{};
    nominal[i].position += Vec2(0.004, -0.003);
    nominal[i].yaw += 0.03;
  }
  SpeedScaleOptions o;
  o.knots = {0.25, 1.0, 2.0};
  const auto fitted = calibrate_exact_speed_scale(nominal, windows(truth, 1500, 2.0, 7), o);
  ASSERT_TRUE(std::holds_alternative<SpeedScaleCalibration>(fitted));
  const auto& cal = std::get<SpeedScaleCalibration>(fitted);
  EXPECT_TRUE(cal.converged) << cal.rounds;
  for (int i = 0; i < 4; ++i) {
    const SensorMount& m = cal.exact.calibrated[i];
    const auto& f = cal.fits[static_cast<std::size_t>(i)];
    const MountVector sd =
        cal.exact.sensors[static_cast<std::size_t>(i)].covariance.diagonal().cwiseSqrt();
    EXPECT_LT((m.position - truth[i].position).norm(), 5.0 * sd.head<2>().norm()) << i;
    EXPECT_LT(std::abs(m.yaw - truth[i].yaw), 5.0 * sd(2)) << i;
    EXPECT_LT(std::abs(m.scale.x() - 1.0), 5.0 * sd(3) + 5.0 * f.sigma[1]) << i;
    ASSERT_TRUE(m.speed_scale.active());
    for (std::size_t k = 1; k < 3; ++k) {
      EXPECT_LT(std::abs(f.ratios[k] - truth[i].speed_scale.ratio(o.knots[k])), 5.0 * f.sigma[k])
          << i << " " << k;
    }
  }
}

}  // namespace
}  // namespace moa
