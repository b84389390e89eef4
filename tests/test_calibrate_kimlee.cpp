// Kim & Lee Section IV as published: the measurement equation, the paper's
// example (eq. (53)), rank deficiency and eq. (49).
#include <gtest/gtest.h>

#include <Eigen/QR>

#include <array>
#include <cmath>
#include <numbers>
#include <random>

#include "moa/calibration/kimlee.hpp"
#include "support/calibration_data.hpp"
#include "support/checks.hpp"

namespace moa {
namespace {

// Eq. (53) in units of 0.3 m, as printed (three decimals).
constexpr std::array<double, 6> kEquation53{0.912, -0.526, 0.000, 1.053, -0.912, -0.526};

SensorArray scaled_positions(SensorArray array, double factor) {
  for (int i = 0; i < array.size(); ++i) array[i].position *= factor;
  return array;
}

Twist2 self_rotation(double) { return {{0.0, 0.0}, 1.0 / 3.0}; }

KimLeeCalibration calibrate(const SensorArray& nominal, const std::vector<CalibrationSample>& s) {
  const auto r = calibrate_kimlee(nominal, s);
  EXPECT_TRUE(std::holds_alternative<KimLeeCalibration>(r));
  return std::get<KimLeeCalibration>(r);
}

TEST(CalibrateKimLee, MeasurementEquationIsTheFirstOrderModel) {
  // Eq. (41): b_k = S_k dp + O(|dp|^2). With true positions p_bar + dp and
  // exact point velocities, |b_k - S_k dp| / |b_k| is of order |dp| / |p|:
  // 1e-6 m on 0.1 m positions gives ~1e-5; 1e-3 is a safe bound.
  std::mt19937_64 rng(3);
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<SensorMount> mounts;
    for (int i = 0; i < 4; ++i) {
      SensorMount m = test::random_mount(rng);
      m.yaw = 0.0;
      m.scale = {1.0, 1.0};
      m.mirrored = false;
      mounts.push_back(m);
    }
    const SensorArray nominal(mounts);
    SensorArray truth = nominal;
    std::normal_distribution<double> g(0.0, 1e-6);
    Eigen::VectorXd dp(8);
    for (int i = 0; i < 4; ++i) {
      dp.segment<2>(2 * i) = Eigen::Vector2d(g(rng), g(rng));
      truth[i].position += dp.segment<2>(2 * i);
    }
    const Twist2 x = test::random_twist(rng);
    std::vector<Eigen::Vector2d> v_s;
    for (int i = 0; i < 4; ++i) v_s.push_back(truth[i].point_jacobian() * x.vector());
    const KimLeeMeasurement m = kimlee_measurement(nominal, x, v_s);
    EXPECT_LT((m.b - m.s * dp).norm(), 1e-3 * m.b.norm()) << "trial " << trial;
  }
}

TEST(CalibrateKimLee, ReproducesEquation53OnThePapersExample) {
  // Section V: N = 3, r = 0.3, theta = -pi/6, truth 1.05 x nominal, omega =
  // 1/3 rad/s, M = 10 noise-free measurements.
  const SensorArray nominal = test::kimlee_nominal();
  const SensorArray truth = scaled_positions(nominal, 1.05);
  const auto samples = test::reference_samples(truth, self_rotation, 1.0, 0.1, false);
  ASSERT_EQ(samples.size(), 10u);
  const KimLeeCalibration cal = calibrate(nominal, samples);
  for (int i = 0; i < 3; ++i) {
    for (int a = 0; a < 2; ++a) {
      // Eq. (53) is printed to three decimals: within 0.0005 of the printed
      // digits, plus the check's 0.002 margin.
      EXPECT_NEAR(cal.calibrated[i].position(a) / 0.3,
                  kEquation53[static_cast<std::size_t>(2 * i + a)], 0.002)
          << "sensor " << i << " axis " << a;
    }
  }
}

TEST(CalibrateKimLee, MinimumNormCorrectionOfSelfRotationIsRadial) {
  // Closed form: with v = 0 only the third row of S carries dp, that row is
  // omega (p_true - 2 p_bar) = -0.95 omega p_bar, and b_3 = -0.05 omega
  // sum |p_bar|^2, so the minimum-norm dp is (0.05 / 0.95) p_bar.
  const SensorArray nominal = test::kimlee_nominal();
  const auto samples =
      test::reference_samples(scaled_positions(nominal, 1.05), self_rotation, 1.0, 0.1, false);
  const KimLeeCalibration cal = calibrate(nominal, samples);
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector2d expected = nominal[i].position * (1.0 + 0.05 / 0.95);
    EXPECT_NEAR((cal.calibrated[i].position - expected).norm(), 0.0, 1e-9) << "sensor " << i;
  }
}

TEST(CalibrateKimLee, SelfRotationIsRankDeficientWithThreeSingularValues) {
  const SensorArray nominal = test::kimlee_nominal();
  const auto samples =
      test::reference_samples(scaled_positions(nominal, 1.05), self_rotation, 1.0, 0.1, false);
  const KimLeeCalibration cal = calibrate(nominal, samples);
  EXPECT_EQ(cal.singular_values.size(), 6);
  EXPECT_EQ(cal.rank, 3);
  EXPECT_TRUE(cal.rank_deficient());
  EXPECT_FALSE(cal.too_few_measurements());  // M = 10 >= 2N - 2 = 4, and still rank 3
  EXPECT_LT(cal.singular_values(3), cal.threshold);
  EXPECT_GT(cal.singular_values(2), cal.threshold);
}

TEST(CalibrateKimLee, QuantisedLogPipelineStillGivesEquation53) {
  // The paper's sensor: ADNS-3080 at 1600 cpi, rows of K = 12 packets at
  // 6400 fps (1.875 ms), integer counts; ten reference intervals of 0.1 s.
  // Each interval sums ~660 counts per sensor, exact to one count (the
  // synthesiser carries the remainder): 1.5e-3 relative, ~0.0005 in units
  // of 0.3 m, inside the 0.002 of the check.
  const SensorArray nominal = test::kimlee_nominal();
  const SensorArray truth = scaled_positions(nominal, 1.05);
  const double row_period = 12.0 / 6400.0;
  const test::SynthLog synth = test::synthesise(truth, self_rotation, 1.05, row_period, true);
  std::vector<double> times;
  for (int k = 0; k <= 10; ++k) times.push_back(0.1 * k);
  IntervalAccumulator acc(3, 0.0, times, 0.05);
  for (const auto& r : synth.rows) {
    ASSERT_FALSE(acc.add(SensorRow{r.t, r.sensor, r.counts, std::nullopt, 0}));
  }
  std::vector<CalibrationSample> samples;
  for (const auto& iv : acc.covered()) samples.push_back({iv.sample, self_rotation(0.0)});
  ASSERT_EQ(samples.size(), 10u);
  const KimLeeCalibration cal = calibrate(nominal, samples);
  EXPECT_EQ(cal.rank, 3);
  for (int i = 0; i < 3; ++i) {
    for (int a = 0; a < 2; ++a) {
      EXPECT_NEAR(cal.calibrated[i].position(a) / 0.3,
                  kEquation53[static_cast<std::size_t>(2 * i + a)], 0.002);
    }
  }
}

TEST(CalibrateKimLee, FewerMeasurementsThanEquation49IsReported) {
  const SensorArray nominal = test::kimlee_nominal();
  const auto samples =
      test::reference_samples(scaled_positions(nominal, 1.05), test::mixed_motion, 0.3, 0.1, false);
  ASSERT_EQ(samples.size(), 3u);  // M = 3 < 2N - 2 = 4
  const KimLeeCalibration cal = calibrate(nominal, samples);
  EXPECT_TRUE(cal.too_few_measurements());
  EXPECT_TRUE(cal.rank_deficient());  // (M + 2) = 5 rows for 6 unknowns
}

TEST(CalibrateKimLee, AnyMotionDeterminesOnlyThreeCombinations) {
  // Row 3 of S_k is, per sensor, v_iy - vy - 2 omega p_ix = omega (p_i - 2 p_bar_i)
  // (and likewise for y) with v_s = v + omega J p exact: the same direction
  // for every k whatever the motion, so S has rank 3 and eq. (49) is never
  // sufficient. Independently: rows 1-2 of S_1 fix the sums of dp exactly,
  // row 3 reads (p - 2 p_bar) . dp = -p_bar . (p - p_bar); the method returns
  // the minimum-norm dp of these three equations.
  const SensorArray nominal = test::kimlee_nominal();
  std::mt19937_64 rng(5);
  const SensorArray truth = test::perturbed(nominal, rng, 0.01, 0.0, 0.0);
  const auto samples = test::reference_samples(truth, test::mixed_motion, 6.0, 0.05, false);
  const KimLeeCalibration cal = calibrate(nominal, samples);
  EXPECT_EQ(cal.rank, 3);

  Eigen::Matrix<double, 3, 6> rows = Eigen::Matrix<double, 3, 6>::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector2d dp = truth[i].position - nominal[i].position;
    rows(0, 2 * i + 1) = 1.0;
    rows(1, 2 * i) = 1.0;
    rows.block<1, 2>(2, 2 * i) = (truth[i].position - 2.0 * nominal[i].position).transpose();
    rhs(0) += dp.y();
    rhs(1) += dp.x();
    rhs(2) -= nominal[i].position.dot(dp);
  }
  const Eigen::Matrix<double, 6, 1> expected = rows.completeOrthogonalDecomposition().solve(rhs);
  EXPECT_LT((cal.delta_p - expected).norm(), 1e-9);
}

TEST(CalibrateKimLee, NoMotionAndNoSamplesAreErrors) {
  const SensorArray nominal = test::kimlee_nominal();
  const auto still = test::reference_samples(
      nominal, [](double) { return Twist2{}; }, 1.0, 0.1, false);
  const auto r = calibrate_kimlee(nominal, still);
  ASSERT_TRUE(std::holds_alternative<CalibrationError>(r));
  EXPECT_EQ(std::get<CalibrationError>(r), CalibrationError::kNoMotion);
  const auto e = calibrate_kimlee(nominal, std::vector<CalibrationSample>{});
  ASSERT_TRUE(std::holds_alternative<CalibrationError>(e));
  EXPECT_EQ(std::get<CalibrationError>(e), CalibrationError::kTooFewSamples);
}

}  // namespace
}  // namespace moa
