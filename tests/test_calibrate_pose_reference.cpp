// The exact calibration against motion capture (calibration/pose_reference.hpp):
// mounts and latencies recovered from a log synthesised here with its own
// clocks (sensor rows stamped late by L_i, fixes by L_r), the coarse search,
// refusals, and the scale unbiased by a noisy reference.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>

#include "moa/calibration/pose_reference.hpp"
#include "support/calibration_data.hpp"
#include "support/slow.hpp"
#include "support/synth.hpp"

namespace moa {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

struct MocapLog {
  std::vector<CountsTrack> tracks;
  std::vector<PoseFix> fixes;
};

struct MocapSetup {
  double duration = 60.0;    // s
  double row_period = 0.01;  // s, every sensor
  double fix_period = 1.0 / 120.0;
  std::vector<double> latency{0.002, 0.005, 0.003, 0.008};  // L_i, s
  double reference_latency = 0.012;                         // L_r, s
  double position_sd = 0.0;                                 // m, per axis and fix
  double theta_sd = 0.0;                                    // rad
  double fix_jitter = 0.0;  // s, each fix's stamp off by a uniform in [-j/2, j/2]
  double fix_drop = 0.0;    // probability a fix is lost
  bool quantise = true;
  test::TwistScript script = test::mixed_motion;
};

// Integrates the script on substeps of 1/2400 s (a common divisor of the
// row and fix periods): a row at true time t is stamped t + L_i and holds
// the counts since the previous row (carried rounding when quantised); a
// fix captured at t is stamped t + L_r.
MocapLog synthesise(const SensorArray& truth, const MocapSetup& s, std::uint64_t seed) {
  const int n = truth.size();
  const double h = 1.0 / 2400.0;
  const auto steps = static_cast<long>(std::llround(s.duration / h));
  const auto per_row = static_cast<long>(std::llround(s.row_period / h));
  const auto per_fix = static_cast<long>(std::llround(s.fix_period / h));
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  MocapLog log;
  log.tracks.assign(static_cast<std::size_t>(n), CountsTrack(0.05));
  std::vector<Eigen::Vector2d> cumulative(static_cast<std::size_t>(n), Eigen::Vector2d::Zero());
  std::vector<Eigen::Vector2d> reported = cumulative;
  Pose2 pose;
  std::uniform_real_distribution<double> uniform(-0.5, 0.5);
  const auto fix = [&](double t) {
    if (s.fix_drop > 0.0 && uniform(rng) + 0.5 < s.fix_drop) return;
    if (s.fix_jitter > 0.0) t += s.fix_jitter * uniform(rng);
    Pose2 p = pose;
    p.t += s.position_sd * Eigen::Vector2d(normal(rng), normal(rng));
    p.theta = wrap_angle(p.theta + s.theta_sd * normal(rng));
    log.fixes.push_back({t + s.reference_latency, p});
  };
  for (int i = 0; i < n; ++i) {
    log.tracks[static_cast<std::size_t>(i)].add(s.latency[static_cast<std::size_t>(i)],
                                                Eigen::Vector2d::Zero(), false);
  }
  fix(0.0);
  for (long k = 1; k <= steps; ++k) {
    const double t = static_cast<double>(k) * h;
    const Twist2 x = s.script(t - 0.5 * h);
    pose = integrate_exact(pose, x, h);
    for (int i = 0; i < n; ++i) cumulative[static_cast<std::size_t>(i)] += truth[i].counts(x, h);
    if (k % per_row == 0) {
      for (int i = 0; i < n; ++i) {
        const auto u = static_cast<std::size_t>(i);
        const Eigen::Vector2d now =
            s.quantise ? Eigen::Vector2d(cumulative[u].array().round()) : cumulative[u];
        log.tracks[u].add(t + s.latency[u], now - reported[u], false);
        reported[u] = now;
      }
    }
    if (k % per_fix == 0) fix(t);
  }
  return log;
}

PoseReferenceCalibration calibrate(const SensorArray& nominal, const MocapLog& log,
                                   const std::vector<double>& latency, double reference_latency,
                                   const PoseReferenceOptions& options = {}) {
  const auto r =
      calibrate_against_poses(nominal, log.tracks, latency, log.fixes, reference_latency, options);
  if (const auto* f = std::get_if<PoseReferenceFailure>(&r)) {
    ADD_FAILURE() << describe(f->error);
    return {};
  }
  return std::get<PoseReferenceCalibration>(r);
}

struct Case {
  SensorArray nominal;
  SensorArray truth;
};

Case four_sensors(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  const SensorArray nominal = test::four_sensor_nominal();
  // Millimetres, degrees and percent off nominal, as the issue's checks.
  return {nominal, test::perturbed(nominal, rng, 0.004, 3.0 * kDeg, 0.03, -1)};
}

double mean(const std::vector<double>& x) {
  double s = 0.0;
  for (double v : x) s += v;
  return s / static_cast<double>(x.size());
}

TEST(CalibratePoseReference, RecoversMountsAndLatenciesFromExactData) {
  // Real-valued counts, exact poses: what is left is the constant-twist
  // approximation over 0.1 s windows (header: ~1e-4 relative).
  const Case c = four_sensors(3);
  MocapSetup s;
  s.quantise = false;
  const MocapLog log = synthesise(c.truth, s, 1);
  // Configured: nominal mounts, latencies all 5 ms (mean of the truth: 4.5 ms), camera 0.
  const std::vector<double> configured(4, 0.0045);
  const PoseReferenceCalibration cal = calibrate(c.nominal, log, configured, 0.0);
  for (int i = 0; i < 4; ++i) {
    const auto u = static_cast<std::size_t>(i);
    const SensorMount& m = cal.exact.calibrated[i];
    EXPECT_LT((m.position - c.truth[i].position).norm(), 2e-5) << i;
    EXPECT_LT(std::abs(wrap_angle(m.yaw - c.truth[i].yaw)), 2e-4) << i;
    EXPECT_LT((m.scale - c.truth[i].scale).cwiseAbs().maxCoeff(), 2e-4) << i;
    EXPECT_TRUE(cal.latency_estimated[u]);
    EXPECT_NEAR(cal.latency[u], s.latency[u], 5e-5) << i;
  }
  // Gauge: the sensors' mean as configured (4.5 ms, the truth's too).
  EXPECT_NEAR(mean(cal.latency), 0.0045, 1e-12);
  EXPECT_NEAR(cal.reference_latency, s.reference_latency, 5e-5);
}

// The issue's motion-capture check: 120 Hz, 0.3 mm, 0.1 deg, 12 ms late;
// every estimate within 4 of its own 1-sigma, and that 1-sigma below the
// issue's limits (0.3 mm, 0.05 deg, 0.15 %, 0.5 ms).
TEST(CalibratePoseReference, MotionCaptureWithinItsOwnSigmaAndTheIssuesLimits) {
  const Case c = four_sensors(5);
  MocapSetup s;
  s.position_sd = 0.3e-3;
  s.theta_sd = 0.1 * kDeg;
  const MocapLog log = synthesise(c.truth, s, 2);
  const std::vector<double> configured(4, mean(s.latency));
  const PoseReferenceCalibration cal = calibrate(c.nominal, log, configured, 0.0);
  for (int i = 0; i < 4; ++i) {
    const auto u = static_cast<std::size_t>(i);
    const SensorMount& m = cal.exact.calibrated[i];
    const MountVector sd = cal.exact.sensors[u].covariance.diagonal().cwiseSqrt();
    const MountVector err = mount_parameters(m) - mount_parameters(c.truth[i]);
    for (int p = 0; p < kMountParameters; ++p) {
      EXPECT_LT(std::abs(p == 2 ? wrap_angle(err(p)) : err(p)), 4.0 * sd(p))
          << "sensor " << i << " parameter " << p;
    }
    EXPECT_LT(sd.head<2>().maxCoeff(), 0.3e-3) << i;
    EXPECT_LT(sd(2), 0.05 * kDeg) << i;
    EXPECT_LT(sd.tail<2>().maxCoeff(), 0.0015) << i;
    EXPECT_LT(std::abs(cal.latency[u] - s.latency[u]), 4.0 * cal.latency_sigma[u]) << i;
    EXPECT_LT(cal.latency_sigma[u], 0.5e-3) << i;
  }
  EXPECT_LT(std::abs(cal.reference_latency - s.reference_latency),
            4.0 * cal.reference_latency_sigma);
  EXPECT_LT(cal.reference_latency_sigma, 0.5e-3);
}

// ------------------------------------------------------------ positions only

std::vector<PositionFix> positions_of(const MocapLog& log) {
  std::vector<PositionFix> out;
  for (const PoseFix& f : log.fixes) out.push_back({f.t, f.pose.t});
  return out;
}

PoseReferenceCalibration calibrate_positions(const SensorArray& nominal, const MocapLog& log,
                                             const std::vector<double>& latency,
                                             double reference_latency) {
  const auto r = calibrate_against_positions(nominal, log.tracks, latency, positions_of(log),
                                             reference_latency);
  if (const auto* f = std::get_if<PoseReferenceFailure>(&r)) {
    ADD_FAILURE() << describe(f->error);
    return {};
  }
  return std::get<PoseReferenceCalibration>(r);
}

// The truth in the gauge's frame: positions seen from positions only are
// those of the robot frame turned so that the sensors' mean yaw is the
// nominal one (delta = the truth's mean yaw change).
SensorArray in_gauge(const SensorArray& truth, const SensorArray& nominal) {
  double sn = 0.0, cs = 0.0;
  for (int i = 0; i < truth.size(); ++i) {
    sn += std::sin(wrap_angle(truth[i].yaw - nominal[i].yaw));
    cs += std::cos(wrap_angle(truth[i].yaw - nominal[i].yaw));
  }
  const double delta = std::atan2(sn, cs);
  std::vector<SensorMount> m(truth.mounts().begin(), truth.mounts().end());
  for (SensorMount& x : m) {
    x.position = rotation(-delta) * x.position;
    x.yaw -= delta;
  }
  return SensorArray(m);
}

TEST(CalibratePoseReference, PositionsOnlyRecoverMountsInTheGaugeFromExactData) {
  MOA_SKIP_UNDER_SANITIZER("a ceiling camera over 30-60 s, about ten passes");
  // Real-valued counts, exact positions at 25 Hz: the heading comes from
  // the array alone; what is left is the windows' approximations.
  const Case c = four_sensors(21);
  MocapSetup s;
  s.quantise = false;
  s.fix_period = 1.0 / 25.0;
  s.reference_latency = 0.06;
  const MocapLog log = synthesise(c.truth, s, 21);
  const std::vector<double> configured(4, mean(s.latency));
  const PoseReferenceCalibration cal = calibrate_positions(c.nominal, log, configured, 0.0);
  ASSERT_TRUE(cal.heading.has_value());
  EXPECT_TRUE(cal.heading->rate_scale_estimated);
  const SensorArray truth = in_gauge(c.truth, c.nominal);
  double sin_sum = 0.0, cos_sum = 0.0;  // the yaw changes' circular mean
  for (int i = 0; i < 4; ++i) {
    const auto u = static_cast<std::size_t>(i);
    const SensorMount& m = cal.exact.calibrated[i];
    EXPECT_LT((m.position - truth[i].position).norm(), 2e-4) << i;
    EXPECT_LT(std::abs(wrap_angle(m.yaw - truth[i].yaw)), 0.02 * kDeg) << i;
    EXPECT_LT((m.scale - truth[i].scale).cwiseAbs().maxCoeff(), 5e-4) << i;
    EXPECT_NEAR(cal.latency[u], s.latency[u], 2e-4) << i;
    sin_sum += std::sin(wrap_angle(m.yaw - c.nominal[i].yaw));
    cos_sum += std::cos(wrap_angle(m.yaw - c.nominal[i].yaw));
  }
  EXPECT_NEAR(std::atan2(sin_sum, cos_sum), 0.0, 1e-12) << "the gauge: the nominal mean yaw";
  EXPECT_NEAR(cal.reference_latency, s.reference_latency, 2e-4);
}

// The issue's ceiling-camera check: positions only at 25 Hz, 2 mm, 60 ms
// late, 5 ms of jitter, 2 % of the fixes dropped; positions within 2 mm,
// yaw (mean removed) 0.25 deg, scale 0.5 %, the sensors' latencies 2 ms and
// the camera's 3 ms. Seeds 41-43 (41-50 in docs/calibration.md; 31-33 were
// used while writing the method).
TEST(CalibratePoseReference, CeilingCameraWithinTheIssuesLimits) {
  MOA_SKIP_UNDER_SANITIZER("a ceiling camera over 30-60 s, about ten passes");
  for (std::uint64_t seed : {41, 42, 43}) {
    const Case c = four_sensors(seed);
    MocapSetup s;
    s.fix_period = 1.0 / 25.0;
    s.position_sd = 2e-3;
    s.reference_latency = 0.06;
    s.fix_jitter = 0.005;
    s.fix_drop = 0.02;
    const MocapLog log = synthesise(c.truth, s, seed);
    const std::vector<double> configured(4, mean(s.latency));
    const PoseReferenceCalibration cal = calibrate_positions(c.nominal, log, configured, 0.0);
    const SensorArray truth = in_gauge(c.truth, c.nominal);
    for (int i = 0; i < 4; ++i) {
      const auto u = static_cast<std::size_t>(i);
      const SensorMount& m = cal.exact.calibrated[i];
      EXPECT_LT((m.position - truth[i].position).norm(), 2e-3) << "seed " << seed << " " << i;
      EXPECT_LT(std::abs(wrap_angle(m.yaw - truth[i].yaw)), 0.25 * kDeg) << seed << " " << i;
      EXPECT_LT((m.scale - truth[i].scale).cwiseAbs().maxCoeff(), 5e-3) << seed << " " << i;
      EXPECT_LT(std::abs(cal.latency[u] - s.latency[u]), 2e-3) << seed << " " << i;
    }
    EXPECT_LT(std::abs(cal.reference_latency - s.reference_latency), 3e-3) << seed;
  }
}

// Without rotation the array's rotation scale (which its positions set) is
// not seen from positions: said (rate_scale_estimated false), the heading
// still fitted, and the positions left to the exact fit's observability
// report (no rotation: positions kept at nominal).
TEST(CalibratePoseReference, PositionsWithoutTurningSayTheRotationScaleIsNotSeen) {
  MOA_SKIP_UNDER_SANITIZER("a ceiling camera over 30-60 s, about ten passes");
  const Case c = four_sensors(23);
  MocapSetup s;
  s.duration = 30.0;
  s.fix_period = 1.0 / 25.0;
  s.position_sd = 1e-3;
  s.script = [](double t) {
    return Twist2{{0.2 + 0.15 * std::sin(0.6 * t), 0.2 * std::cos(0.45 * t + 0.3)}, 0.0};
  };
  const MocapLog log = synthesise(c.truth, s, 23);
  const std::vector<double> configured(4, mean(s.latency));
  const PoseReferenceCalibration cal = calibrate_positions(c.nominal, log, configured, 0.0);
  ASSERT_TRUE(cal.heading.has_value());
  EXPECT_FALSE(cal.heading->rate_scale_estimated);
  EXPECT_LT(cal.heading->rotation_range, 0.5);
  for (int i = 0; i < 4; ++i) {
    const auto& est = cal.exact.sensors[static_cast<std::size_t>(i)].estimated;
    EXPECT_FALSE(est[0] && est[1]) << "position of sensor " << i << " without rotation";
  }
}

TEST(CalibratePoseReference, PositionsFromAnotherRunAreRefused) {
  const Case c = four_sensors(9);
  MocapSetup s;
  s.duration = 30.0;
  s.fix_period = 1.0 / 25.0;
  const MocapLog mice = synthesise(c.truth, s, 5);
  MocapSetup other = s;
  other.script = [](double t) { return test::mixed_motion(t + 17.0); };
  const MocapLog camera = synthesise(c.truth, other, 6);
  const std::vector<double> configured(4, mean(s.latency));
  const auto r =
      calibrate_against_positions(c.nominal, mice.tracks, configured, positions_of(camera), 0.0);
  ASSERT_TRUE(std::holds_alternative<PoseReferenceFailure>(r));
  EXPECT_EQ(std::get<PoseReferenceFailure>(r).error, PoseReferenceError::kNoCorrelation);
}

TEST(CalibratePoseReference, CoarseSearchFindsLargeOffsets) {
  const Case c = four_sensors(7);
  MocapSetup s;
  s.duration = 30.0;
  s.reference_latency = 0.4;
  const std::vector<double> configured(4, mean(s.latency));
  {
    const MocapLog log = synthesise(c.truth, s, 3);
    const PoseReferenceCalibration cal = calibrate(c.nominal, log, configured, 0.0);
    // The grid is 5 ms, the parabola refines it; the fit does the rest.
    EXPECT_NEAR(cal.coarse_latency, 0.4, 0.005);
    EXPECT_NEAR(cal.reference_latency, 0.4, 1e-3);
  }
  s.reference_latency = 2.5;
  const MocapLog log = synthesise(c.truth, s, 4);
  PoseReferenceOptions options;
  options.max_offset = 3.0;
  const PoseReferenceCalibration cal = calibrate(c.nominal, log, configured, 0.0, options);
  EXPECT_NEAR(cal.coarse_latency, 2.5, 0.005);
  EXPECT_NEAR(cal.reference_latency, 2.5, 1e-3);
  // Within the default +-1 s the alignment is outside the range: refused.
  const auto refused = calibrate_against_poses(c.nominal, log.tracks, configured, log.fixes, 0.0);
  ASSERT_TRUE(std::holds_alternative<PoseReferenceFailure>(refused));
  EXPECT_EQ(std::get<PoseReferenceFailure>(refused).error, PoseReferenceError::kNoCorrelation);
}

TEST(CalibratePoseReference, ReferenceFromAnotherRunIsRefused) {
  const Case c = four_sensors(9);
  MocapSetup s;
  s.duration = 30.0;
  const MocapLog mice = synthesise(c.truth, s, 5);
  MocapSetup other = s;
  // Another run: the same kind of motion, other phases.
  other.script = [](double t) { return test::mixed_motion(t + 17.0); };
  const MocapLog camera = synthesise(c.truth, other, 6);
  const std::vector<double> configured(4, mean(s.latency));
  const auto r = calibrate_against_poses(c.nominal, mice.tracks, configured, camera.fixes, 0.0);
  ASSERT_TRUE(std::holds_alternative<PoseReferenceFailure>(r));
  const auto& f = std::get<PoseReferenceFailure>(r);
  EXPECT_EQ(f.error, PoseReferenceError::kNoCorrelation);
  EXPECT_LT(f.correlation, 0.5);
}

TEST(CalibratePoseReference, BadInputsAreRefused) {
  const Case c = four_sensors(11);
  MocapSetup s;
  s.duration = 10.0;
  const MocapLog log = synthesise(c.truth, s, 7);
  const std::vector<double> configured(4, 0.0);
  const auto error_of = [&](const std::vector<PoseFix>& fixes) {
    const auto r = calibrate_against_poses(c.nominal, log.tracks, configured, fixes, 0.0);
    return std::holds_alternative<PoseReferenceFailure>(r)
               ? std::optional(std::get<PoseReferenceFailure>(r).error)
               : std::nullopt;
  };
  std::vector<PoseFix> nan = log.fixes;
  nan[100].pose.t.x() = std::nan("");
  EXPECT_EQ(error_of(nan), PoseReferenceError::kBadInput);
  std::vector<PoseFix> back = log.fixes;
  back[100].t = back[99].t;
  EXPECT_EQ(error_of(back), PoseReferenceError::kBadInput);
  const std::vector<PoseFix> few(log.fixes.begin() + 200, log.fixes.begin() + 260);  // 0.5 s
  EXPECT_EQ(error_of(few), PoseReferenceError::kTooFewFixes);
  // A latency per sensor is needed.
  const std::vector<double> three(3, 0.0);
  const auto r = calibrate_against_poses(c.nominal, log.tracks, three, log.fixes, 0.0);
  ASSERT_TRUE(std::holds_alternative<PoseReferenceFailure>(r));
  EXPECT_EQ(std::get<PoseReferenceFailure>(r).error, PoseReferenceError::kBadInput);
}

// A noisy reference must not shrink the scales (the errors-in-variables
// model). With fixes ten times noisier than the issue's motion capture
// (3 mm, 1 deg), ordinary least squares on the windows' displacements
// shrinks every scale by about var(noise) / var(motion) (here ~-2 %); the
// exact fit's mean error over seeds is below a tenth of that. (It is not
// zero: +0.08 % here, +0.007 % at the issue's 0.3 mm, about +0.025 % per mm
// of fix noise: docs/calibration.md.)
TEST(CalibratePoseReference, NoisyReferenceDoesNotShrinkTheScale) {
  MOA_SKIP_UNDER_SANITIZER("a ceiling camera over 30-60 s, about ten passes");
  const Case c = four_sensors(13);
  MocapSetup s;
  s.duration = 30.0;
  s.position_sd = 3e-3;
  s.theta_sd = 1.0 * kDeg;
  const std::vector<double> configured(4, mean(s.latency));
  constexpr int kSeeds = 6;
  std::vector<double> eiv, ols;
  PoseReferenceOptions plain;
  plain.exact.errors_in_variables = false;
  for (int seed = 0; seed < kSeeds; ++seed) {
    const MocapLog log = synthesise(c.truth, s, 100 + static_cast<std::uint64_t>(seed));
    for (auto* out : {&eiv, &ols}) {
      const PoseReferenceCalibration cal =
          calibrate(c.nominal, log, configured, 0.0, out == &eiv ? PoseReferenceOptions{} : plain);
      double e = 0.0;
      for (int i = 0; i < 4; ++i) {
        e += (cal.exact.calibrated[i].scale - c.truth[i].scale).sum() / 8.0;
      }
      out->push_back(e);
    }
  }
  EXPECT_LT(mean(ols), -0.005) << "least squares should shrink the scales";
  EXPECT_LT(std::abs(mean(eiv)), 0.1 * std::abs(mean(ols)));
}

}  // namespace
}  // namespace moa
