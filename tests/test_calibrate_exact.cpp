// The exact method: noise-free recovery, the paper's example (eq. (52)),
// observability of degenerate motions, errors in variables, outliers, and
// the Monte Carlo error against the Cramer-Rao bound.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <cmath>
#include <numbers>
#include <random>

#include "moa/calibration/exact.hpp"
#include "support/calibration_data.hpp"

namespace moa {
namespace {

ExactCalibration calibrate(const SensorArray& nominal, const std::vector<CalibrationSample>& s,
                           const ExactOptions& options = {}) {
  const auto r = calibrate_exact(nominal, s, options);
  if (const auto* e = std::get_if<CalibrationError>(&r)) {
    ADD_FAILURE() << describe(*e);
    return {};
  }
  return std::get<ExactCalibration>(r);
}

Twist2 self_rotation(double) { return {{0.0, 0.0}, 1.0 / 3.0}; }

// Largest differences between two arrays: position (m), yaw (rad), scale.
struct Errors {
  double position = 0.0, yaw = 0.0, scale = 0.0;
  bool mirrored_match = true;
};
Errors errors(const SensorArray& a, const SensorArray& b) {
  Errors e;
  for (int i = 0; i < a.size(); ++i) {
    e.position = std::max(e.position, (a[i].position - b[i].position).cwiseAbs().maxCoeff());
    e.yaw = std::max(e.yaw, std::abs(wrap_angle(a[i].yaw - b[i].yaw)));
    e.scale = std::max(e.scale, (a[i].scale - b[i].scale).cwiseAbs().maxCoeff());
    e.mirrored_match = e.mirrored_match && a[i].mirrored == b[i].mirrored;
  }
  return e;
}

TEST(CalibrateExact, RecoversRandomExtrinsicsFromNoiseFreeData) {
  // Real-valued counts and an exact reference: the model holds exactly, so
  // the fit must land on the truth up to the optimiser's tolerance.
  std::mt19937_64 rng(11);
  for (int trial = 0; trial < 3; ++trial) {
    const SensorArray nominal = test::four_sensor_nominal();
    const SensorArray truth = test::perturbed(nominal, rng, 0.008, 0.07, 0.04, trial);
    const auto samples = test::reference_samples(truth, test::mixed_motion, 8.0, 0.02, false);
    const ExactCalibration cal = calibrate(nominal, samples);
    const Errors e = errors(cal.calibrated, truth);
    EXPECT_LT(e.position, 1e-7) << "trial " << trial;
    EXPECT_LT(e.yaw, 1e-6) << "trial " << trial;
    EXPECT_LT(e.scale, 1e-6) << "trial " << trial;
    EXPECT_TRUE(e.mirrored_match) << "trial " << trial;
    EXPECT_TRUE(cal.sensors[static_cast<std::size_t>(trial)].mirror_from_data);
    for (const auto& s : cal.sensors) {
      for (bool estimated : s.estimated) EXPECT_TRUE(estimated);
    }
  }
}

TEST(CalibrateExact, RecoversThePapersTruePositionsEquation52) {
  // Kim & Lee Section V. Pure rotation shows only q_i = M_i J p_i: yaw and
  // scale stay nominal (as they truly are here) and the positions follow
  // exactly, 1.05 x nominal (eq. (52)), within the check's 0.5 mm.
  const SensorArray nominal = test::kimlee_nominal();
  SensorArray truth = nominal;
  for (int i = 0; i < 3; ++i) truth[i].position *= 1.05;
  const auto samples = test::reference_samples(truth, self_rotation, 1.0, 0.1, false);
  ASSERT_EQ(samples.size(), 10u);
  const ExactCalibration cal = calibrate(nominal, samples);
  for (int i = 0; i < 3; ++i) {
    EXPECT_LT((cal.calibrated[i].position - truth[i].position).norm(), 1e-9) << "sensor " << i;
    const auto& est = cal.sensors[static_cast<std::size_t>(i)].estimated;
    EXPECT_TRUE(est[0] && est[1]);
    EXPECT_FALSE(est[2] || est[3] || est[4]) << "yaw and scale are not excited by pure rotation";
    EXPECT_EQ(cal.calibrated[i].yaw, nominal[i].yaw);
    EXPECT_EQ(cal.calibrated[i].scale, nominal[i].scale);
  }
}

TEST(CalibrateExact, QuantisedPapersExampleWithinHalfAMillimetre) {
  // ADNS-3080 rows of 12 packets at 6400 fps, integer counts, ten 0.1 s
  // reference intervals: ~660 counts per interval exact to one count, so
  // positions to ~0.3 m * 1.5e-3 / sqrt(10) = 0.15 mm at worst.
  const SensorArray nominal = test::kimlee_nominal();
  SensorArray truth = nominal;
  for (int i = 0; i < 3; ++i) truth[i].position *= 1.05;
  const test::SynthLog synth = test::synthesise(truth, self_rotation, 1.05, 12.0 / 6400.0, true);
  std::vector<double> times;
  for (int k = 0; k <= 10; ++k) times.push_back(0.1 * k);
  IntervalAccumulator acc(3, 0.0, times, 0.05);
  for (const auto& r : synth.rows) acc.add(SensorRow{r.t, r.sensor, r.counts, std::nullopt, 0});
  std::vector<CalibrationSample> samples;
  for (const auto& iv : acc.covered()) samples.push_back({iv.sample, self_rotation(0.0)});
  ASSERT_EQ(samples.size(), 10u);
  const ExactCalibration cal = calibrate(nominal, samples);
  for (int i = 0; i < 3; ++i) {
    EXPECT_LT((cal.calibrated[i].position - truth[i].position).norm(), 5e-4) << "sensor " << i;
  }
}

TEST(CalibrateExact, NoRotationKeepsPositionsAtNominal) {
  // Pure translation: q_i is never seen, so the positions cannot be told.
  const SensorArray nominal = test::four_sensor_nominal();
  std::mt19937_64 rng(2);
  SensorArray truth = test::perturbed(nominal, rng, 0.0, 0.05, 0.03);
  const auto translate = [](double t) {
    return Twist2{{0.2 * std::sin(0.7 * t), 0.2 * std::cos(0.5 * t)}, 0.0};
  };
  const auto samples = test::reference_samples(truth, translate, 8.0, 0.02, false);
  const ExactCalibration cal = calibrate(nominal, samples);
  for (int i = 0; i < 4; ++i) {
    const auto& s = cal.sensors[static_cast<std::size_t>(i)];
    EXPECT_FALSE(s.estimated[0] || s.estimated[1]) << "sensor " << i;
    EXPECT_TRUE(s.estimated[2] && s.estimated[3] && s.estimated[4]) << "sensor " << i;
    EXPECT_EQ(s.calibrated.position, nominal[i].position);
    EXPECT_NEAR(wrap_angle(s.calibrated.yaw - truth[i].yaw), 0.0, 1e-7);
    EXPECT_LT((s.calibrated.scale - truth[i].scale).cwiseAbs().maxCoeff(), 1e-7);
  }
}

TEST(CalibrateExact, CalibratedYawKeepsTheNominalsRepresentation) {
  // A config may write a yaw as 3.78 rad (216 deg) rather than -2.5 rad:
  // the calibrated yaw must come back within pi of it, so that the config
  // written reads as a small change, and a yaw kept at nominal is unchanged.
  SensorArray nominal = test::four_sensor_nominal();
  nominal[2].yaw += 2.0 * std::numbers::pi;
  nominal[3].yaw += 2.0 * std::numbers::pi;
  std::mt19937_64 rng(12);
  const SensorArray truth = test::perturbed(nominal, rng, 0.008, 0.07, 0.04, 1);
  const auto mixed = test::reference_samples(truth, test::mixed_motion, 8.0, 0.02, false);
  const ExactCalibration cal = calibrate(nominal, mixed);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(cal.calibrated[i].yaw, truth[i].yaw, 1e-6) << i;

  const auto spin = test::reference_samples(truth, self_rotation, 8.0, 0.02, false);
  const ExactCalibration kept = calibrate(nominal, spin);
  for (int i = 0; i < 4; ++i) {
    ASSERT_FALSE(kept.sensors[static_cast<std::size_t>(i)].estimated[2]);
    EXPECT_EQ(kept.calibrated[i].yaw, nominal[i].yaw) << i;
  }
}

TEST(CalibrateExact, NoLateralMotionKeepsOneScaleAtNominal) {
  // vy = 0: only M_i e_x and q_i are seen, four numbers for five parameters.
  // A sensor aligned with the robot (yaw 0) then cannot see its y scale;
  // one turned by 90 deg cannot see its x scale.
  std::vector<SensorMount> m(3);
  m[0].position = {0.1, 0.0};
  m[1].position = {-0.05, 0.09};
  m[1].yaw = std::numbers::pi / 2.0;
  m[2].position = {-0.05, -0.09};
  m[2].yaw = 0.0;
  const SensorArray nominal(m);
  SensorArray truth = nominal;
  truth[0].position += Eigen::Vector2d(0.003, -0.002);
  truth[1].position += Eigen::Vector2d(-0.002, 0.004);
  truth[2].yaw += 0.02;
  truth[0].scale.x() = 1.02;
  truth[1].scale.y() = 0.98;
  const auto forward_and_turn = [](double t) {
    return Twist2{{0.2 + 0.1 * std::sin(0.8 * t), 0.0}, 0.8 * std::sin(0.5 * t)};
  };
  const auto samples = test::reference_samples(truth, forward_and_turn, 8.0, 0.02, false);
  const ExactCalibration cal = calibrate(nominal, samples);
  const auto& s0 = cal.sensors[0].estimated;
  const auto& s1 = cal.sensors[1].estimated;
  EXPECT_FALSE(s0[4]) << "sensor 0 (yaw 0) must keep its y scale";
  EXPECT_TRUE(s0[0] && s0[1] && s0[2] && s0[3]);
  EXPECT_FALSE(s1[3]) << "sensor 1 (yaw 90 deg) must keep its x scale";
  EXPECT_TRUE(s1[0] && s1[1] && s1[2] && s1[4]);
  EXPECT_LT(errors(cal.calibrated, truth).position, 1e-7);
  EXPECT_LT(errors(cal.calibrated, truth).yaw, 1e-6);
  EXPECT_LT(errors(cal.calibrated, truth).scale, 1e-6);
}

TEST(CalibrateExact, NoisyReferenceGivesUnbiasedScaleWhereLeastSquaresIsBiased) {
  // Errors in variables. With reference noise sigma on each axis, ordinary
  // least squares shrinks M_i by about sigma^2 / (sigma^2 + E[v^2]): here
  // 0.03^2 / (0.03^2 + 0.051) = 1.7 % along x and 0.03^2 / (0.03^2 + 0.020)
  // = 4.3 % along y, each sensor axis a mix of the two. The exact method
  // must stay within 4 of its own 1-sigma of the truth, OLS must be off by
  // more than 1 %.
  const SensorArray nominal = test::four_sensor_nominal();
  std::mt19937_64 rng(4);
  const SensorArray truth = test::perturbed(nominal, rng, 0.005, 0.05, 0.03);
  const auto samples =
      test::reference_samples(truth, test::mixed_motion, 10.0, 0.02, true, {0.03, 0.1}, 9);
  const ExactCalibration eiv = calibrate(nominal, samples);
  ExactOptions ols_options;
  ols_options.errors_in_variables = false;
  const ExactCalibration ols = calibrate(nominal, samples, ols_options);
  for (int i = 0; i < 4; ++i) {
    const auto& s = eiv.sensors[static_cast<std::size_t>(i)];
    for (int a = 0; a < 2; ++a) {
      const double sd = std::sqrt(s.covariance(3 + a, 3 + a));
      EXPECT_LT(std::abs(s.calibrated.scale(a) - truth[i].scale(a)), 4.0 * sd)
          << "sensor " << i << " axis " << a;
      EXPECT_GT(std::abs(ols.calibrated[i].scale(a) - truth[i].scale(a)), 0.01);
    }
    const double sd_x = std::sqrt(s.covariance(0, 0));
    EXPECT_LT(std::abs(s.calibrated.position.x() - truth[i].position.x()), 4.0 * sd_x);
  }
  // The estimated reference noise is the simulated one (relative error of a
  // standard deviation from 500 samples: ~sqrt(1/1000) = 3 %; 10 % bounds it).
  EXPECT_NEAR(std::sqrt(eiv.noise.reference_covariance(0, 0)), 0.03, 0.003);
  EXPECT_NEAR(std::sqrt(eiv.noise.reference_covariance(2, 2)), 0.1, 0.01);
}

TEST(CalibrateExact, RejectsReferenceOutliers) {
  // Five wheel-slip spikes of 0.5 m/s among 400 samples: rejected, and the
  // result is as good as without them.
  const SensorArray nominal = test::four_sensor_nominal();
  std::mt19937_64 rng(6);
  const SensorArray truth = test::perturbed(nominal, rng, 0.005, 0.05, 0.03, 2);
  auto samples = test::reference_samples(truth, test::mixed_motion, 8.0, 0.02, false, {1e-4, 1e-4});
  for (int j = 0; j < 5; ++j) samples[static_cast<std::size_t>(50 + 70 * j)].reference.v.x() += 0.5;
  const ExactCalibration cal = calibrate(nominal, samples);
  EXPECT_EQ(cal.samples_rejected, 5);
  EXPECT_FALSE(cal.model_misfit);
  EXPECT_TRUE(errors(cal.calibrated, truth).mirrored_match);
  // What is left is the 1e-4 reference noise: within 5 of the reported sd.
  for (int i = 0; i < 4; ++i) {
    const auto& s = cal.sensors[static_cast<std::size_t>(i)];
    const MountVector d = mount_parameters(s.calibrated) - mount_parameters(truth[i]);
    for (int p = 0; p < kMountParameters; ++p) {
      EXPECT_LT(std::abs(p == 2 ? wrap_angle(d(p)) : d(p)), 5.0 * std::sqrt(s.covariance(p, p)))
          << "sensor " << i << " parameter " << p;
    }
  }
}

TEST(CalibrateExact, MonteCarloErrorIsNearTheCramerRaoBound) {
  // Gaussian count noise (0.5 count) and reference noise (1 cm/s, 0.03
  // rad/s), known to the estimator, on a fixed motion; T trials. For an
  // efficient estimator each parameter's mean squared error over T trials
  // is CRB * chi2(T) / T: with T = 40 the 1e-4 two-sided bounds of chi2(40)/40
  // are [0.37, 2.02]. A biased estimator (OLS here: -0.5 % scale bias, ~5x
  // its sd) falls outside them.
  const SensorArray nominal = test::kimlee_nominal();
  std::mt19937_64 rng(8);
  const SensorArray truth = test::perturbed(nominal, rng, 0.005, 0.05, 0.03);
  const auto clean = test::reference_samples(truth, test::mixed_motion, 5.0, 0.025, false);
  const double count_sd = 0.5;
  const test::ReferenceNoise ref{0.01, 0.03};
  ExactOptions options;
  options.noise = CalibrationNoise{};
  options.noise->counts_variance.assign(3, count_sd * count_sd);
  options.noise->reference_covariance =
      Eigen::Vector3d(ref.speed * ref.speed, ref.speed * ref.speed, ref.rate * ref.rate)
          .asDiagonal();
  std::vector<Twist2> twists;
  std::vector<double> dts;
  for (const auto& s : clean) {
    twists.push_back(s.reference);
    dts.push_back(s.mice.dt);
  }
  const Eigen::MatrixXd crb = calibration_information(truth, twists, dts, *options.noise).inverse();

#ifdef NDEBUG
  const int trials = 40;
#else
  const int trials = 8;  // unoptimised (sanitizer) builds: the bounds below follow T
#endif
  Eigen::VectorXd sq = Eigen::VectorXd::Zero(15);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int t = 0; t < trials; ++t) {
    auto samples = clean;
    for (auto& s : samples) {
      for (int i = 0; i < 3; ++i) {
        s.mice.counts[static_cast<std::size_t>(i)] += count_sd * Eigen::Vector2d(g(rng), g(rng));
      }
      s.reference.v += ref.speed * Eigen::Vector2d(g(rng), g(rng));
      s.reference.omega += ref.rate * g(rng);
    }
    const ExactCalibration cal = calibrate(nominal, samples, options);
    for (int i = 0; i < 3; ++i) {
      MountVector d = mount_parameters(cal.calibrated[i]) - mount_parameters(truth[i]);
      d(2) = wrap_angle(d(2));
      sq.segment<5>(5 * i) += d.cwiseAbs2();
    }
  }
  // chi2(T) / T quantiles 1e-4 and 1 - 1e-4 (Wilson-Hilferty, z = 3.719).
  const auto quantile = [&](double z) {
    const double a = 2.0 / (9.0 * trials);
    return std::pow(1.0 - a + z * std::sqrt(a), 3.0);
  };
  for (int p = 0; p < 15; ++p) {
    const double ratio = sq(p) / trials / crb(p, p);
    EXPECT_GT(ratio, quantile(-3.719)) << "parameter " << p;
    EXPECT_LT(ratio, quantile(3.719)) << "parameter " << p;
  }
}

TEST(CalibrateExact, TooFewSamplesAndNoMotionAreErrors) {
  const SensorArray nominal = test::four_sensor_nominal();
  const auto two = test::reference_samples(nominal, test::mixed_motion, 0.04, 0.02, false);
  ASSERT_EQ(two.size(), 2u);
  const auto r = calibrate_exact(nominal, two);
  ASSERT_TRUE(std::holds_alternative<CalibrationError>(r));
  EXPECT_EQ(std::get<CalibrationError>(r), CalibrationError::kTooFewSamples);
  const auto still = test::reference_samples(
      nominal, [](double) { return Twist2{}; }, 0.5, 0.02, false);
  const auto s = calibrate_exact(nominal, still);
  ASSERT_TRUE(std::holds_alternative<CalibrationError>(s));
  EXPECT_EQ(std::get<CalibrationError>(s), CalibrationError::kNoMotion);
}

}  // namespace
}  // namespace moa
