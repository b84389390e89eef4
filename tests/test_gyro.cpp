// The gyro as a source of the consensus estimator (core/gyro.hpp,
// core/kalman.hpp): the shared Kalman update against the information form,
// the gyro's calibration states against their closed forms, the bridge of a
// common-mode dropout, and imu.csv.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <vector>

#include "moa/core/chi2.hpp"
#include "moa/core/consensus.hpp"
#include "moa/core/gyro.hpp"
#include "moa/core/kalman.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/diagnostics_csv.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/log.hpp"
#include "moa/formats/odometry_csv.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa {
namespace {

constexpr double kDt = 0.01;

TEST(Kalman, JosephUpdateEqualsTheInformationForm) {
  // Posterior by the information form: P+^-1 = P^-1 + H^T R^-1 H,
  // x+ = P+ (P^-1 x + H^T R^-1 z): an independent computation.
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    Mat<3, 3> a;
    for (int i = 0; i < 9; ++i) a(i / 3, i % 3) = n(rng);
    const Mat3 p = a * a.transpose() + Mat3::Identity() * 0.1;
    const Vec3 x(n(rng), n(rng), n(rng));
    Mat<2, 3> h;
    for (int i = 0; i < 6; ++i) h(i / 3, i % 3) = n(rng);
    const Mat2 r = Vec2(0.3, 0.7).asDiagonal();
    const Vec2 z(n(rng), n(rng));
    Vec3 xj = x;
    Mat3 pj = p;
    joseph_update<3, 2>(xj, pj, Vec2(z - h * x), h, r);
    const Mat3 info = p.inverse() + h.transpose() * r.inverse() * h;
    const Mat3 pi = info.inverse();
    const Vec3 xi = pi * (p.inverse() * x + h.transpose() * r.inverse() * z);
    EXPECT_LT((pj - pi).norm(), 1e-9 * pi.norm()) << trial;
    EXPECT_LT((xj - xi).norm(), 1e-9 * (1.0 + xi.norm())) << trial;
  }
}

TEST(Kalman, GateAtTheChiSquareQuantile) {
  // A 1-D innovation of exactly sqrt(q) standard deviations sits on the gate.
  const real gate = static_cast<real>(chi2_quantile(1.0 - 1e-3, 1));
  Mat<1, 1> x(0.0), p(1.0);
  const Mat<1, 1> h(1.0), r(1.0);
  const real sd = std::sqrt(2.0);  // S = P + R
  const AidStatus in = gated_update<1, 1>(x, p, Mat<1, 1>(0.99 * sd * std::sqrt(gate)), h, r, gate);
  EXPECT_TRUE(in.fused);
  EXPECT_NEAR(in.test_ratio, 0.99 * 0.99, 1e-12);
  Mat<1, 1> x2(0.0), p2(1.0);
  const AidStatus out =
      gated_update<1, 1>(x2, p2, Mat<1, 1>(1.01 * sd * std::sqrt(gate)), h, r, gate);
  EXPECT_FALSE(out.fused);
  EXPECT_EQ(x2(0), 0.0);
  EXPECT_EQ(p2(0), 1.0);
}

TEST(Gyro, AtRestTheBiasIsTheMeanReadingWithItsClosedFormVariance) {
  // At rest with an exact array (zero twist, zero covariance) and no bias
  // walk, each reading is the bias plus noise of variance d^2/dt: the
  // posterior of b is the conjugate normal's, 1/P = 1/P0 + N dt/d^2 (a
  // window's angle is a sufficient statistic of its readings).
  GyroOptions o;
  o.bias_random_walk = 0.0;
  GyroModel gyro(o, 0.1);
  // No gate: a gated window is rejected at the rate alpha even when honest,
  // and the closed form counts every reading.
  const real gate = std::numeric_limits<real>::infinity();
  std::mt19937 rng(11);
  const double bias = 0.013, sd = o.noise_density / std::sqrt(kDt);
  std::normal_distribution<double> noise(0.0, sd);
  const int n = 2000;
  double sum = 0.0;
  for (int k = 0; k < n; ++k) {
    const double g = bias + noise(rng);
    sum += g;
    gyro.predict(kDt, g);
    gyro.teach(g, kDt, Vec3::Zero(), 0.0, 0.0, gate);
  }
  (void)gyro.close(gate);  // the last window, whole or not
  const double p0 = o.bias_sigma * o.bias_sigma;
  const double expected_var = 1.0 / (1.0 / p0 + n / (sd * sd));
  EXPECT_NEAR(gyro.covariance()(0, 0), expected_var, 1e-6 * expected_var);
  // The posterior mean: the prior (0) and the sample mean, weighed.
  const double expected_mean = expected_var * (sum / (sd * sd));
  EXPECT_NEAR(gyro.bias(), expected_mean, 1e-6);
  EXPECT_NEAR(gyro.bias(), bias, 4.0 * std::sqrt(expected_var));
}

TEST(Gyro, TurningInPlaceTeachesTheScale) {
  // The array turning in place at known rates (exact, v = 0): g = k w + c.
  GyroOptions o;
  o.bias_random_walk = 0.0;
  GyroModel gyro(o, 0.1);
  const real gate = static_cast<real>(chi2_quantile(1.0 - 1e-3, 1));
  std::mt19937 rng(12);
  std::normal_distribution<double> noise(0.0, o.noise_density / std::sqrt(kDt));
  const double k = 1.021, c = -0.02;
  for (int i = 0; i < 3000; ++i) {
    const double w = 2.0 * std::sin(0.01 * i);
    const double g = k * w + c + noise(rng);
    gyro.predict(kDt, g);
    gyro.teach(g, kDt, Vec3(0, 0, w), 0.0, 0.0, gate);
  }
  EXPECT_NEAR(gyro.scale(), k, 4.0 * std::sqrt(gyro.covariance()(1, 1)));
  EXPECT_NEAR(gyro.bias(), c, 4.0 * std::sqrt(gyro.covariance()(0, 0)));
  EXPECT_LT(std::sqrt(gyro.covariance()(1, 1)), 1e-3);  // from 3 % to under 0.1 %
}

TEST(Gyro, DrivingTeachesTheArraysRotationCouplingToItsVelocity) {
  // An array whose rotation reads a . v on top of the truth (a sensor's yaw
  // mount error on a compact array), a calibrated gyro: a is learnt along
  // the direction driven, and decouple() removes it from the array's twist.
  GyroOptions o;
  o.bias_random_walk = 0.0;
  o.bias_sigma = 1e-4;
  o.scale_sigma = 1e-4;
  GyroModel gyro(o, 0.015);
  const real gate = static_cast<real>(chi2_quantile(1.0 - 1e-3, 1));
  std::mt19937 rng(13);
  std::normal_distribution<double> noise(0.0, o.noise_density / std::sqrt(kDt));
  const double ax = 0.05;  // rad/m
  for (int i = 0; i < 2000; ++i) {
    const double vx = 0.3 * (1.0 + std::sin(0.003 * i)), w = 0.2 * std::sin(0.02 * i);
    const double g = w + noise(rng);
    gyro.predict(kDt, g);
    gyro.teach(g, kDt, Vec3(vx, 0, w + ax * vx), 1e-8, 1e-6, gate);
  }
  EXPECT_NEAR(gyro.coupling().x(), ax, 4.0 * std::sqrt(gyro.covariance()(2, 2)));
  Vec3 x(0.4, 0.0, 0.1 + ax * 0.4);
  Mat3 cov = Mat3::Zero();
  gyro.decouple(x, cov);
  EXPECT_NEAR(x(2), 0.1, 4.0 * 0.4 * std::sqrt(gyro.covariance()(2, 2)));
  EXPECT_NEAR(cov(2, 2), 0.16 * gyro.covariance()(2, 2), 1e-15);
}

TEST(Gyro, RateVarianceIsTheNoiseAndTheStatesPropagated) {
  GyroOptions o;
  o.scale = 1.1;
  o.bias = 0.02;
  const GyroModel gyro(o, 0.1);
  const real g = 1.0;
  const auto r = gyro.rate(g, kDt);
  ASSERT_TRUE(r);
  const double w = (g - 0.02) / 1.1;
  EXPECT_NEAR(r->omega, w, 1e-12);
  // d w / d b = -1/k, d w / d s = -w (at s = 0), independent states.
  const double var = o.noise_density * o.noise_density / (kDt * 1.1 * 1.1) +
                     o.bias_sigma * o.bias_sigma / (1.1 * 1.1) +
                     w * w * o.scale_sigma * o.scale_sigma;
  EXPECT_NEAR(r->variance, var, 1e-12);
}

TEST(Gyro, ASaturatedOrNonFiniteReadingIsNotARate) {
  GyroOptions o;
  o.max_rate = 4.0;
  const GyroModel gyro(o, 0.1);
  EXPECT_TRUE(gyro.rate(0.97 * 4.0, kDt));
  EXPECT_FALSE(gyro.rate(0.99 * 4.0, kDt));
  EXPECT_FALSE(gyro.rate(-4.0, kDt));
  EXPECT_FALSE(gyro.rate(std::nan(""), kDt));
}

TEST(Gyro, AnEpochOfAnotherSourcesRotationGrowsTheHeadingErrorByItsOwnVariance) {
  // The gyro drives the heading for a while (delta gets a variance and
  // correlations with the bias and scale), then another source's rotation of
  // variance v is reported: delta's variance grows by v dt^2 exactly, the
  // calibration's block is untouched, and the heading error known so far is
  // not forgotten (drive() would have grown it by the gyro's own noise).
  GyroOptions o;
  GyroModel gyro(o, 0.1);
  for (int k = 0; k < 50; ++k) {
    gyro.predict(kDt, 0.7);
    const auto r = gyro.rate(0.7, kDt);
    ASSERT_TRUE(r);
    (void)gyro.drive(*r, kDt);
  }
  const Mat<GyroModel::kStates, GyroModel::kStates> before = gyro.covariance();
  ASSERT_GT(before(5, 5), 0.0);
  const double v = 4e-4;
  (void)gyro.hold(v, kDt);
  const Mat<GyroModel::kStates, GyroModel::kStates> after = gyro.covariance();
  EXPECT_NEAR(after(5, 5), before(5, 5) + v * kDt * kDt, 1e-12 * before(5, 5));
  const Mat<5, 5> calibration = after.topLeftCorner<5, 5>() - before.topLeftCorner<5, 5>();
  const Mat<5, 1> correlation = after.block<5, 1>(0, 5) - before.block<5, 1>(0, 5);
  EXPECT_EQ(calibration.cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(correlation.cwiseAbs().maxCoeff(), 0.0);
}

// The mean over (t - dt, t] of omega(u - tau) = w sin(f u): a gyro whose
// rows cover an interval ending tau s before their stamp's.
double late_rate(double w, double f, double t, double dt, double tau) {
  return w * (std::cos(f * (t - dt - tau)) - std::cos(f * (t - tau))) / (f * dt);
}

TEST(Gyro, ALatencyLeftIsLearntFromTheTurnsAccelerations) {
  // Turning at w sin(f t) (up to 3.1 rad/s^2) with a good array, the
  // gyro's rows 6 ms later than the config says: the latency is learnt to
  // within its sd, which falls well under the 5 ms prior, and the scale and
  // bias learnt beside it are the true ones (a latency taken for scale
  // would bias it).
  GyroOptions o;
  o.bias_random_walk = 0.0;
  o.latency = 0.002;
  GyroModel gyro(o, 0.1);
  const real gate = static_cast<real>(chi2_quantile(1.0 - 1e-3, 1));
  std::mt19937 rng(15);
  std::normal_distribution<double> noise(0.0, o.noise_density / std::sqrt(kDt));
  // The array's rotation: noise of variance n = 1e-6 rad^2/s^2 an epoch (as
  // taught), its quantisation q = 1e-8 rad^2 not drawn (the chain's
  // residual, bounded).
  std::normal_distribution<double> array_noise(0.0, 1e-3);
  const double k = 1.012, c = 0.01, tau = 0.006, w = 2.5, f = 1.25;
  for (int i = 1; i <= 3000; ++i) {
    const double t = i * kDt;
    const double g = k * late_rate(w, f, t, kDt, tau) + c + noise(rng);
    gyro.predict(kDt, g);
    gyro.teach(g, kDt, Vec3(0, 0, late_rate(w, f, t, kDt, 0.0) + array_noise(rng)), 1e-8, 1e-6,
               gate);
  }
  EXPECT_NEAR(gyro.latency(), o.latency + tau, 4.0 * gyro.latency_sd());
  EXPECT_LT(gyro.latency_sd(), 0.1 * o.latency_sigma);
  EXPECT_NEAR(gyro.scale(), k, 4.0 * gyro.scale_sd());
  EXPECT_NEAR(gyro.bias(), c, 4.0 * gyro.bias_sd());
  // The rate is taken forward by the latency: at the last epoch's end the
  // corrected rate is within 4 sd of the true mean rate over it.
  const double t = 3001 * kDt;
  const double g = k * late_rate(w, f, t, kDt, tau) + c;
  gyro.predict(kDt, g);
  const auto r = gyro.rate(g, kDt);
  ASSERT_TRUE(r);
  const double truth = late_rate(w, f, t, kDt, 0.0);
  const double uncorrected = (g - gyro.bias()) / gyro.scale();
  EXPECT_NEAR(r->omega, truth, 4.0 * std::sqrt(r->variance));
  EXPECT_LT(std::abs(r->omega - truth), 0.2 * std::abs(uncorrected - truth));
}

TEST(Gyro, AtRestAndAtASteadyRateTheLatencyDoesNotMove) {
  // Readings that do not change beyond their noise carry nothing about the
  // latency: its estimate and sd stay at the prior, exactly.
  GyroOptions o;
  o.bias_random_walk = 0.0;
  GyroModel gyro(o, 0.1);
  const real gate = static_cast<real>(chi2_quantile(1.0 - 1e-3, 1));
  std::mt19937 rng(16);
  std::normal_distribution<double> noise(0.0, o.noise_density / std::sqrt(kDt));
  for (int i = 0; i < 4000; ++i) {
    const double w = i < 2000 ? 0.0 : 1.3;
    const double g = w + noise(rng);
    gyro.predict(kDt, g);
    // The step and the epoch after it (whose window would take the step's
    // change as its start's) are no window: a step is a change of rate.
    if (i != 2000 && i != 2001) {
      gyro.teach(g, kDt, Vec3(0, 0, w), 0.0, 0.0, gate);
    } else {
      (void)gyro.close(gate);
    }
  }
  EXPECT_EQ(gyro.latency(), o.latency);
  EXPECT_EQ(gyro.latency_sd(), o.latency_sigma);
  EXPECT_LT(gyro.bias_sd(), 0.1 * o.bias_sigma);  // the other states did learn
}

// A gyro turning at w sin(f t) against an exact array for n epochs, its
// bias c plus `step` from epoch `at` on (noise from rng).
void turn(GyroModel& gyro, int n, int at, double c, double step, std::mt19937& rng) {
  const real gate = static_cast<real>(chi2_quantile(1.0 - 1e-3, 1));
  std::normal_distribution<double> noise(0.0, gyro.options().noise_density / std::sqrt(kDt));
  for (int i = 1; i <= n; ++i) {
    const double w = 0.8 * std::sin(0.5 * i * kDt);
    const double g = w + c + (i >= at ? step : 0.0) + noise(rng);
    gyro.predict(kDt, g);
    gyro.teach(g, kDt, Vec3(0, 0, w), 1e-8, 1e-6, gate);
  }
}

TEST(Gyro, ABiasStepIsFoundAndTheBiasLearntAfresh) {
  // 20 s with the bias learnt, then a step of 0.02 rad/s (a knock): without
  // the step's test the bias walks at 1e-4 rad/s/sqrt(s) and would need
  // minutes; with it, 3 s after the step the bias is the new one to within
  // 4 sd, and the step was counted once.
  GyroOptions o;
  const double c = 0.01, step = 0.02;
  GyroModel gyro(o, 0.1);
  std::mt19937 rng(17);
  turn(gyro, 2000, 1 << 30, c, 0.0, rng);
  ASSERT_EQ(gyro.bias_resets(), 0);
  ASSERT_LT(gyro.bias_sd(), 0.002);  // learnt, and far narrower than the step
  turn(gyro, 300, 1, c, step, rng);
  EXPECT_EQ(gyro.bias_resets(), 1);
  EXPECT_NEAR(gyro.bias(), c + step, 4.0 * gyro.bias_sd());
  // A run of the same length with no step raises no alarm (one an hour
  // under the model).
  GyroModel steady(o, 0.1);
  std::mt19937 rng2(18);
  turn(steady, 2300, 1 << 30, c, 0.0, rng2);
  EXPECT_EQ(steady.bias_resets(), 0);
}

SensorArray compact_array() {
  std::vector<SensorMount> m(4);
  for (int k = 0; k < 4; ++k) {
    const double phi = std::numbers::pi / 4.0 + k * std::numbers::pi / 2.0;
    m[static_cast<std::size_t>(k)].position = 0.015 * Eigen::Vector2d(std::cos(phi), std::sin(phi));
    m[static_cast<std::size_t>(k)].yaw = phi;
  }
  return SensorArray(m);
}

TEST(Gyro, ACommonModeDropoutWhileTurningTakesTheGyrosRotation) {
  // Turning in place at 1.5 rad/s; every sensor reads zero for 0.3 s; no
  // wheels. Without the gyro the hold keeps the last twist; with it the
  // bridge's rotation is the gyro's (here a true one: 1.2 rad/s from the
  // dropout on, which the hold cannot know).
  const SensorArray a = compact_array();
  auto made = ConsensusEstimator::create(a);
  ASSERT_TRUE(std::holds_alternative<ConsensusEstimator>(made));
  auto& est = std::get<ConsensusEstimator>(made);
  double t = 0.0;
  // Counts with a little noise (identical counts epoch after epoch are a
  // frozen register to the health monitor).
  std::mt19937 rng(14);
  std::normal_distribution<double> noise(0.0, 0.05);
  const auto sample = [&](const Twist2& x) {
    ArraySample s;
    t += kDt;
    s.t = t;
    s.dt = kDt;
    s.size = a.size();
    for (int i = 0; i < a.size(); ++i) {
      s.counts[static_cast<std::size_t>(i)] = a[i].counts(x, kDt) + Vec2(noise(rng), noise(rng));
      s.squal[static_cast<std::size_t>(i)] = 90;
    }
    return s;
  };
  const Twist2 turn{{0.0, 0.0}, 1.5};
  for (int k = 0; k < 300; ++k) {
    const auto e = est.estimate(sample(turn), std::nullopt, real(1.5));
    ASSERT_TRUE(e);
    ASSERT_EQ(e->source, Source::kMice) << k;
  }
  int bridged = 0;
  for (int k = 0; k < 30; ++k) {
    const auto e = est.estimate(sample(Twist2{}), std::nullopt, real(1.2));
    ASSERT_TRUE(e);
    if (e->source != Source::kMice) {
      ++bridged;
      EXPECT_TRUE(e->tests.gyro_fused);
      // The gyro rejected the array's standstill, or the health monitor had
      // left no sensor to test (NaN).
      EXPECT_FALSE(e->tests.gyro <= 1.0) << k;

      EXPECT_NEAR(e->estimate.twist.omega, 1.2, 4.0 * std::sqrt(e->estimate.covariance(2, 2)));
    }
  }
  EXPECT_EQ(bridged, 30);
}

TEST(Gyro, AStuckGyroIsBlamedAndTheRotationIsTheArrays) {
  // Turning in place at 1.5 rad/s, then slowing down at 2 rad/s^2 (a tenth of
  // the robot's angular limit) to 0.5 rad/s, held for 1 s, while the gyro
  // stays stuck at 1.5 rad/s; no wheels. The array agrees with itself and
  // with the motion prior all along: the gyro is the one blamed, the array's
  // rotation is reported and the heading follows the truth, where the stuck
  // gyro's rotation would turn it by 1.25 rad too far.
  const SensorArray a = compact_array();
  auto made = ConsensusEstimator::create(a);
  ASSERT_TRUE(std::holds_alternative<ConsensusEstimator>(made));
  auto& est = std::get<ConsensusEstimator>(made);
  double t = 0.0;
  std::mt19937 rng(15);
  std::normal_distribution<double> noise(0.0, 0.05);
  const auto sample = [&](const Twist2& x) {
    ArraySample s;
    t += kDt;
    s.t = t;
    s.dt = kDt;
    s.size = a.size();
    for (int i = 0; i < a.size(); ++i) {
      s.counts[static_cast<std::size_t>(i)] = a[i].counts(x, kDt) + Vec2(noise(rng), noise(rng));
      s.squal[static_cast<std::size_t>(i)] = 90;
    }
    return s;
  };
  for (int k = 0; k < 300; ++k) {
    ASSERT_TRUE(est.estimate(sample(Twist2{{0.0, 0.0}, 1.5}), std::nullopt, real(1.5)));
  }
  double heading_error = 0.0, stuck_error = 0.0;  // rad, the estimate's and the gyro's
  int rejected = 0, held = 0;
  for (int k = 1; k <= 150; ++k) {
    const double w = std::max(0.5, 1.5 - 2.0 * k * kDt);
    const auto e = est.estimate(sample(Twist2{{0.0, 0.0}, w}), std::nullopt, real(1.5));
    ASSERT_TRUE(e);
    EXPECT_EQ(e->source, Source::kMice) << k;  // never bridged: the array is right
    heading_error += (e->estimate.twist.omega - w) * kDt;
    stuck_error += (1.5 - w) * kDt;
    if (w == 0.5) {
      ++held;
      if (e->tests.gyro_rejected) {
        ++rejected;
        EXPECT_FALSE(e->tests.gyro_fused) << k;
        EXPECT_NEAR(e->estimate.twist.omega, w, 4.0 * std::sqrt(e->estimate.covariance(2, 2)));
      }
    }
  }
  EXPECT_NEAR(stuck_error, 1.25, 0.01);
  EXPECT_EQ(rejected, held);
  // Before the gyro is blamed its error grows until it leaves the gate
  // (about sqrt(q(1 - 1e-3, 1)) times the two rates' sd, 0.1 rad/s here: a
  // few tens of mrad over the deceleration); a tenth of the gyro's error
  // bounds that with room.
  EXPECT_LT(std::abs(heading_error), 0.1 * stuck_error);
}

TEST(Gyro, AtRestTheWheelsLetTheGyroLearnItsBiasToItsOwnNoise) {
  // A compact array at rest whose counts carry noise (0.3 counts per epoch
  // per axis), a gyro biased by 0.01 rad/s. With wheels that read nothing
  // the robot is known still: each reading is the bias plus noise of variance
  // d^2 / dt, so the bias's posterior is the conjugate normal's,
  // 1 / P = 1 / P0 + N dt / d^2 (no bias walk). Without wheels the array's
  // noisy standstill is all there is: the bias is known worse (here about
  // sqrt(q) / T, q the angle variance of the counts' quantisation: 0.2 mrad/s
  // over 2 s, twice the gyro's own).
  const SensorArray a = compact_array();
  ConsensusOptions o;
  o.gyro.bias_random_walk = 0.0;
  const double d = o.gyro.noise_density, bias = 0.01, sd = d / std::sqrt(kDt);
  const auto run = [&](bool wheels, unsigned seed) {
    auto made = ConsensusEstimator::create(a, o);
    auto& est = std::get<ConsensusEstimator>(made);
    std::mt19937 rng(seed);
    std::normal_distribution<double> counts(0.0, 0.3), gyro(bias, sd);
    for (int k = 1; k <= 200; ++k) {
      ArraySample s;
      s.t = k * kDt;
      s.dt = kDt;
      s.size = a.size();
      for (int i = 0; i < a.size(); ++i) {
        s.counts[static_cast<std::size_t>(i)] =
            Vec2(std::round(counts(rng)), std::round(counts(rng)));
        s.squal[static_cast<std::size_t>(i)] = 90;
      }
      const auto e =
          est.estimate(s, wheels ? std::optional<Twist2>(Twist2{}) : std::nullopt, real(gyro(rng)));
      EXPECT_TRUE(e && e->source == Source::kMice);
    }
    return std::pair<double, double>(est.gyro().bias(), std::sqrt(est.gyro().covariance()(0, 0)));
  };
  const double p0 = o.gyro.bias_sigma * o.gyro.bias_sigma;
  const double expected_sd = std::sqrt(1.0 / (1.0 / p0 + 200.0 / (sd * sd)));
  const auto [still_bias, still_sd] = run(true, 21);
  EXPECT_NEAR(still_sd, expected_sd, 0.01 * expected_sd);
  EXPECT_NEAR(still_bias, bias, 4.0 * expected_sd);
  const auto [moving_bias, moving_sd] = run(false, 21);
  EXPECT_GT(moving_sd, 1.5 * expected_sd);
  EXPECT_NEAR(moving_bias, bias, 4.0 * moving_sd);
}

TEST(ImuCsv, ReadsRowsAndRefusesBadOnes) {
  const auto dir = std::filesystem::temp_directory_path() / "moa_test_imu_csv";
  std::filesystem::create_directories(dir);
  const auto write = [&](const std::string& text) {
    std::ofstream(dir / "imu.csv") << text;
    return dir / "imu.csv";
  };
  const auto rows = io::read_all<io::ImuRow>(write("# c\nt,gz\n0,0.5\n0.01,-0.25\n"));
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[1].t, 0.01);
  EXPECT_EQ(rows[1].gz, -0.25);
  const auto error = [&](const std::string& text) {
    try {
      (void)io::read_all<io::ImuRow>(write(text));
    } catch (const io::Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error("t,wz\n0,1\n").find("missing column 'gz'"), std::string::npos);
  EXPECT_NE(error("t,gz\n0,nan\n").find("imu.csv:2"), std::string::npos);
  EXPECT_NE(error("t,gz\n1,0\n0.5,0\n").find("imu.csv:3"), std::string::npos);
  std::filesystem::remove_all(dir);
}

// moa odometry on scenario gyro-bump (three dropouts of every sensor while
// turning in place, a compact array, slipping wheels, a gyro 2 % off and
// biased): with the gyro no bump moves the heading (each is bridged by the
// gyro's rotation), without it each costs degrees; diagnostics.csv reports
// the gyro fused in the bridged epochs.
TEST(GyroCli, BumpsAreBridgedByTheGyrosRotation) {
  namespace fs = std::filesystem;
  const fs::path dir = test::scratch_dir("gyro-cli");
  const std::string log = (dir / "log").string();
  ASSERT_EQ(test::run_moa("simulate --scenario gyro-bump --seed 101 --out " + log).exit_code, 0);
  const auto truth = io::read_all<io::TruthRow>(log + "/truth.csv");
  const io::RobotConfig config = io::read_config(log + "/robot.yaml");
  // Heading error (rad, wrapped) at each odometry row, truth by time (both
  // at 100 Hz on the same clock).
  const auto heading_errors = [&](const std::string& flags) {
    const std::string out = (dir / ("o" + std::to_string(flags.size()) + ".csv")).string();
    const auto r = test::run_moa("odometry --config " + log + "/robot.yaml --log " + log +
                                 " --out " + out + " " + flags);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    std::vector<std::pair<double, double>> errors;
    io::OdometryCsvReader odometry(out, config, log + "/robot.yaml");
    std::size_t k = 0;
    while (const auto o = odometry.next()) {
      while (k + 1 < truth.size() && truth[k + 1].t <= o->t + 1e-9) ++k;
      errors.emplace_back(
          o->t, std::remainder(o->pose.theta - truth[k].pose.theta, 2.0 * std::numbers::pi));
    }
    return errors;
  };
  const auto step_over = [](const std::vector<std::pair<double, double>>& e, double a, double b) {
    double before = 0.0, after = 0.0;
    for (const auto& [t, err] : e) {
      if (t <= a) before = err;
      if (t <= b) after = err;
    }
    return std::abs(after - before);
  };
  const auto fused = heading_errors("--diagnostics " + (dir / "d.csv").string());
  const auto alone = heading_errors("--no-imu");
  for (const double start : {35.1, 82.9, 130.7}) {
    // The gyro's rate over 0.4 s is known to a few mrad/s: far under 0.5 deg.
    EXPECT_LT(step_over(fused, start - 0.05, start + 0.35), 0.5 * std::numbers::pi / 180.0)
        << start;
    // Without it the wheels' slip and the array's standstill cost more.
    EXPECT_GT(step_over(alone, start - 0.05, start + 0.35),
              step_over(fused, start - 0.05, start + 0.35))
        << start;
  }
  // Over the whole run the gyro's heading (its bias learnt at the rests, its
  // scale in the turns, what its calibration left taken back as the array
  // teaches it) is better than the array's own, bridged or not.
  const auto worst = [](const std::vector<std::pair<double, double>>& e) {
    double m = 0.0;
    for (const auto& p : e) m = std::max(m, std::abs(p.second));
    return m;
  };
  EXPECT_LT(worst(fused), worst(alone));
  // The gyro's status: fused in every epoch bridged by the wheels.
  std::size_t bridged = 0;
  for (const auto& d : io::read_diagnostics_csv(dir / "d.csv")) {
    if (d.source == "wheels" && d.fused) ++bridged;
  }
  EXPECT_GE(bridged, 3u);
  std::size_t imu_fused = 0, imu_rows = 0;
  for (const auto& d : io::read_diagnostics_csv(dir / "d.csv")) {
    if (d.source != "imu") continue;
    ++imu_rows;
    if (d.fused) ++imu_fused;
  }
  // Every epoch has the gyro's status but the first ones: the gyro's first
  // row only opens its record (at 10 ms, 5 ms late), so epochs before its
  // second row have no reading.
  EXPECT_LE(imu_rows, fused.size());
  EXPECT_GE(imu_rows + 3, fused.size());
  EXPECT_GE(imu_fused, bridged);
}

// One sensor and a gyro (scenario gyro-one, an OTOS-class robot): the
// sensor gives the translation, the gyro every rotation. The same log run
// with the gyro's true scale (robot.true.yaml: 1.02) and with the believed
// one (robot.yaml: 1): the rotation is the gyro's reading over its scale in
// both, and the bias is learnt at the same rests (omega = 0 there, whatever
// the scale), so the believed run turns 2 % more: its final heading exceeds
// the other's by 0.02 times the latter's, up to the two bias priors' pull
// (centred on 0.01 and 0 rad/s, sd 0.05, against readings that pin the bias
// to about 0.3 mrad/s: 1e-5 of the difference). Without the gyro one sensor
// is refused, saying why.
TEST(GyroCli, OneSensorTakesItsRotationFromTheGyro) {
  namespace fs = std::filesystem;
  const fs::path dir = test::scratch_dir("gyro-one");
  const std::string log = (dir / "log").string();
  ASSERT_EQ(test::run_moa("simulate --scenario gyro-one --seed 102 --out " + log).exit_code, 0);
  const auto final_heading = [&](const std::string& config) {
    const std::string out = (dir / (config + ".csv")).string();
    const auto r = test::run_moa("odometry --config " + log + "/" + config + ".yaml --log " + log +
                                 " --out " + out);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    const io::RobotConfig c = io::read_config(log + "/" + config + ".yaml");
    io::OdometryCsvReader odometry(out, c, log + "/" + config + ".yaml");
    double theta = 0.0;
    std::size_t rows = 0;
    while (const auto o = odometry.next()) {
      theta = o->pose.theta;
      ++rows;
    }
    EXPECT_GT(rows, 14000u);
    return theta;
  };
  const double believed = final_heading("robot"), known = final_heading("robot.true");
  const auto truth = io::read_all<io::TruthRow>(log + "/truth.csv");
  ASSERT_FALSE(truth.empty());
  EXPECT_GT(known, 18.0);  // five and a half turns (unwrapped)
  EXPECT_NEAR(believed - known, 0.02 * known, 1e-3 * 0.02 * known);
  // With its scale known the gyro's heading is the truth's to its noise and
  // bias (d sqrt(T) = 2 mrad; a bias known to 0.3 mrad/s over 144 s, 40 mrad).
  EXPECT_NEAR(known, truth.back().pose.theta, 0.05);
  const auto refused = test::run_moa("odometry --config " + log + "/robot.yaml --log " + log +
                                     " --out " + (dir / "no.csv").string() + " --no-imu");
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_NE(refused.err.find("one sensor needs a gyro for its rotation: --no-imu given"),
            std::string::npos)
      << refused.err;
  EXPECT_FALSE(fs::exists(dir / "no.csv"));
  // An imu.csv with one data row gives no rotation at all: refused too.
  std::ofstream(log + "/imu.csv") << "t,gz\n0,0\n";
  const auto empty = test::run_moa("odometry --config " + log + "/robot.yaml --log " + log +
                                   " --out " + (dir / "no.csv").string());
  EXPECT_EQ(empty.exit_code, 1);
  EXPECT_NE(empty.err.find("imu.csv has 1 data row (the first only opens an interval)"),
            std::string::npos)
      << empty.err;
  EXPECT_FALSE(fs::exists(dir / "no.csv"));
}

// Two sensors and a gyro, m2 reading nothing for 20 s in a cruise (no lift
// flag): the pair disagrees, the health monitor names m2 (zero), and m1 with
// the gyro's rotation carries on alone, an array of one, where without the
// gyro the epochs would fall back to the slipping wheels. The scenario is
// gyro-one's with a second sensor opposite the first.
TEST(GyroCli, TwoSensorsAndAGyroCarryOnWithTheSoundOne) {
  namespace fs = std::filesystem;
  const fs::path dir = test::scratch_dir("gyro-two");
  std::ifstream in(std::string(MOA_TEST_DATA_DIR) + "/../../examples/scenarios/gyro-one.yaml");
  std::stringstream text;
  text << in.rdbuf();
  std::string yaml = text.str();
  const auto replace = [&](const std::string& from, const std::string& to) {
    const auto at = yaml.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    yaml.replace(at, from.size(), to);
  };
  replace("names: [m1]", "names: [m1, m2]");
  replace("angles_deg: [45]", "angles_deg: [45, 225]");
  replace("true_sensors:\n",
          "faults:\n  events:\n    - {type: liftoff, sensor: m2, start: 40.0, end: 60.0, "
          "squal: 90, lift_flag: false}\ntrue_sensors:\n");
  std::ofstream(dir / "two.yaml") << yaml;
  const std::string log = (dir / "log").string();
  const auto sim = test::run_moa("simulate --scenario " + (dir / "two.yaml").string() +
                                 " --seed 103 --out " + log);
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  const std::string out = (dir / "o.csv").string();
  const auto r =
      test::run_moa("odometry --config " + log + "/robot.true.yaml --log " + log + " --out " + out);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // odometry.csv's source and used columns, by header.
  std::ifstream csv(out);
  std::string line;
  std::getline(csv, line);
  std::vector<std::string> header;
  for (std::stringstream ss(line); std::getline(ss, line, ',');) header.push_back(line);
  const auto column = [&](const std::string& name) {
    return static_cast<std::size_t>(std::find(header.begin(), header.end(), name) - header.begin());
  };
  const std::size_t t_col = column("t"), source_col = column("source"), used_col = column("used");
  ASSERT_LT(used_col, header.size());
  std::size_t in_fault = 0, m1_alone = 0, mice = 0;
  while (std::getline(csv, line)) {
    std::vector<std::string> f;
    for (std::stringstream ss(line); std::getline(ss, line, ',');) f.push_back(line);
    if (f.size() < header.size()) f.resize(header.size());
    const double t = std::stod(f[t_col]);
    if (t < 42.0 || t > 59.0) continue;  // the health monitor's verdict takes a moment
    ++in_fault;
    if (f[source_col] == "mice") ++mice;
    if (f[source_col] == "mice" && f[used_col] == "m1") ++m1_alone;
  }
  EXPECT_GT(in_fault, 1600u);
  // The mice's twist nearly throughout (a few epochs in turns go to the
  // common-mode bridge), m1 alone in most of them: m2's zero agrees with m1
  // only at the rests (0.3 s at each corner, where the pair is used).
  EXPECT_GT(mice, in_fault * 95 / 100);
  EXPECT_GT(m1_alone, in_fault * 85 / 100);
}

}  // namespace
}  // namespace moa
