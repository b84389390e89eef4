// Online self-calibration (core/self_calibration.hpp, docs/self-calibration.md):
// options, the CSV it writes, and its properties on simulated logs over the
// test seeds 101-105 (thresholds were tuned on seeds 1-2), with margins from
// the paired run-to-run spread rather than recorded outputs.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <regex>
#include <sstream>
#include <string>
#include <variant>
#include <vector>

#include "moa/core/chi2.hpp"
#include "moa/core/consensus.hpp"
#include "moa/core/health.hpp"
#include "moa/core/odometry.hpp"
#include "moa/core/self_calibration.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

double max_error(const std::string& json) {
  std::smatch m;
  const std::regex re("\"max_translation_m\": ([-+0-9.eE]+)");
  if (!std::regex_search(json, m, re)) ADD_FAILURE() << json;
  return m.empty() ? 0.0 : std::stod(m[1]);
}

struct PairedRun {
  double plain = 0.0, calibrated = 0.0, oracle = 0.0;
  /// sensor -> the last row's scale_x, scale_y, yaw_offset: applied, the
  /// filter's, and the filter's standard deviations
  std::map<std::string, std::vector<double>> last, last_filter, last_sd;
  /// Epochs (t) of the self-calibrated run whose `excluded` names m3 frozen,
  /// and those that name m2 for any reason.
  std::vector<double> m3_frozen, m2_out;
  long epochs = 0;             ///< rows of the self-calibrated run
  std::string calibrated_err;  ///< the self-calibrated run's stderr
};

// The `excluded` column of odometry.csv: the epochs where it holds `what`.
std::vector<double> epochs_excluding(const fs::path& csv, const std::string& what) {
  std::ifstream in(csv);
  std::string line;
  std::vector<double> t;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line[0] == 't') continue;
    const auto comma = line.rfind(',');
    if (line.find(what, comma) != std::string::npos) t.push_back(std::stod(line));
  }
  return t;
}

PairedRun run_scenario(const std::string& scenario, int seed, bool oracle = false) {
  const fs::path dir = test::scratch_dir("self-calibration-" + scenario);
  const std::string log = (dir / "log").string(), cfg = (dir / "log" / "robot.yaml").string();
  const auto sim = test::run_moa("simulate --scenario " + scenario + " --seed " +
                                 std::to_string(seed) + " --out " + log);
  EXPECT_EQ(sim.exit_code, 0) << sim.err;
  PairedRun r;
  for (const bool cal : {false, true}) {
    const std::string out = (dir / (cal ? "cal.csv" : "plain.csv")).string();
    const auto odo = test::run_moa(
        "odometry --quiet --config " + cfg + " --log " + log + " --out " + out +
        (cal ? " --self-calibration " + (dir / "estimates.csv").string() : std::string()));
    EXPECT_EQ(odo.exit_code, 0) << odo.err;
    const auto ev =
        test::run_moa("evaluate --json --truth " + log + "/truth.csv --odometry " + out);
    EXPECT_EQ(ev.exit_code, 0) << ev.err;
    (cal ? r.calibrated : r.plain) = max_error(ev.out);
    if (cal) {
      r.calibrated_err = odo.err;
      r.m3_frozen = epochs_excluding(out, "m3:frozen");
      r.m2_out = epochs_excluding(out, "m2:");
      r.epochs = static_cast<long>(epochs_excluding(out, "").size());
    }
  }
  if (oracle) {
    const std::string out = (dir / "oracle.csv").string();
    const auto odo = test::run_moa("odometry --quiet --estimator oracle --config " + cfg +
                                   " --log " + log + " --out " + out);
    EXPECT_EQ(odo.exit_code, 0) << odo.err;
    const auto ev =
        test::run_moa("evaluate --json --truth " + log + "/truth.csv --odometry " + out);
    EXPECT_EQ(ev.exit_code, 0) << ev.err;
    r.oracle = max_error(ev.out);
  }
  std::ifstream in(dir / "estimates.csv");
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line,
            "t,sensor,scale_x,scale_y,yaw_offset,filter_scale_x,filter_scale_y,filter_yaw_offset,"
            "filter_sd_scale_x,filter_sd_scale_y,filter_sd_yaw_offset");
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string t, name, f[9];
    std::getline(ss, t, ',');
    std::getline(ss, name, ',');
    for (auto& x : f) std::getline(ss, x, ',');
    r.last[name] = {std::stod(f[0]), std::stod(f[1]), std::stod(f[2])};
    r.last_filter[name] = {std::stod(f[3]), std::stod(f[4]), std::stod(f[5])};
    r.last_sd[name] = {std::stod(f[6]), std::stod(f[7]), std::stod(f[8])};
  }
  fs::remove_all(dir);
  return r;
}

// One-sided paired bound at 99 % on 5 seeds (t = 3.747) plus the 0.5 mm
// quantisation floor of the experiments' tests.
void not_worse(const std::vector<double>& a, const std::vector<double>& b, const char* what) {
  const auto n = static_cast<double>(a.size());
  double mean = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k) mean += (a[k] - b[k]) / n;
  double var = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    var += (a[k] - b[k] - mean) * (a[k] - b[k] - mean) / (n - 1.0);
  }
  EXPECT_LE(mean, 3.747 * std::sqrt(var / n) + 5e-4) << what;
}

TEST(SelfCalibration, UntouchedArrayKeepsIdentityCorrection) {
  const SensorArray array = regular_polygon(4, 0.1, 0.0);
  SelfCalibration cal(array, SelfCalibrationOptions{});
  ArraySample s;
  s.size = 4;
  s.counts[0] = {12.0, -7.0};
  cal.correct(s);
  EXPECT_EQ(s.counts[0], Eigen::Vector2d(12.0, -7.0));
  EXPECT_EQ(cal.calibration(2).scale_x, 1.0);
  EXPECT_FALSE(cal.runaway(1));
}

// The consensus with its self-calibration states, default options.
std::variant<ConsensusEstimator, GeometryError> self_calibrating_consensus(
    const SensorArray& array) {
  SelfCalibrationOptions calibration;
  calibration.enabled = true;
  return ConsensusEstimator::create(array, ConsensusOptions{}, calibration);
}

// The runaway test's other side: a sensor 20 % off, inside the tolerance of
// a sound sensor (runaway_scale, 25 %) by far more than z sd of its
// estimate, is never a runaway: it is corrected (its estimate within 1 % of
// the truth at the end) and used again once its estimate settles.
TEST(SelfCalibration, ASensorWithinItsToleranceIsCorrectedNotARunaway) {
  const SensorArray array = regular_polygon(4, 0.1, 0.0);
  auto built = self_calibrating_consensus(array);
  ASSERT_TRUE(std::holds_alternative<ConsensusEstimator>(built));
  ConsensusEstimator& consensus = std::get<ConsensusEstimator>(built);
  const real dt = 0.01, off = 1.2;
  int used_late = 0;
  for (int e = 1; e <= 2000; ++e) {
    const double t = e * dt;
    const ArraySample s =
        test::exact_sample(array, test::mixed_motion(t), t, dt,
                           [&](int i) -> Mat2 { return (i == 1 ? off : 1.0) * Mat2::Identity(); });
    const auto r = consensus.estimate(s);
    ASSERT_TRUE(r.has_value());
    EXPECT_NE(r->excluded[1], Exclusion::kCalibration) << t;
    if (t >= 15.0 && contains(r->estimate.used, 1)) ++used_late;
  }
  const auto* c = consensus.self_calibration();
  EXPECT_FALSE(c->runaway(1));
  EXPECT_NEAR(c->calibration(1).scale_x, off, 0.01 * off);
  EXPECT_NEAR(c->calibration(1).scale_y, off, 0.01 * off);
  // From 15 s to the end (501 epochs) it is used in nearly every epoch.
  EXPECT_GE(used_late, 490);
}

// The hold is a test of the estimate's motion against the filter's model of
// a steady calibration (docs/math.md, "The hold"): that model lets a scale's
// estimate move from its 1 s average by about 0.65 % sd (scale_walk 1 %/sqrt(s),
// 0.1 s blocks), so the hold at hold_alpha = 0.05 fires beyond 1.28 % and a
// ramp faster than about 1.4 %/s is held. Noise-free counts: a sensor 10 %
// off is corrected and, once its estimate is steady, used; its resolution
// then ramps by a further 10 % at 5 %/s (from 20 to 22 s): it is held
// within the ramp, and used again once its estimate has settled.
TEST(SelfCalibration, ASensorIsHeldWhileItsCalibrationMovesFasterThanTheModelLets) {
  const SensorArray array = regular_polygon(4, 0.1, 0.0);
  auto built = self_calibrating_consensus(array);
  ASSERT_TRUE(std::holds_alternative<ConsensusEstimator>(built));
  ConsensusEstimator& consensus = std::get<ConsensusEstimator>(built);
  const auto* c = consensus.self_calibration();
  ASSERT_NE(c, nullptr);
  const real dt = 0.01;
  auto scale = [](double t) { return 1.1 + 0.1 * std::clamp((t - 20.0) / 2.0, 0.0, 1.0); };
  int held_steady = 0, held_ramp = 0, used_after = 0, after = 0;
  for (int e = 1; e <= 3500; ++e) {
    const double t = e * dt;
    const ArraySample s = test::exact_sample(
        array, test::mixed_motion(t), t, dt,
        [&](int i) -> Mat2 { return (i == 1 ? scale(t) : 1.0) * Mat2::Identity(); });
    const auto r = consensus.estimate(s);
    ASSERT_TRUE(r.has_value());
    const bool held = c->held_as_drift(1);
    if (t >= 12.0 && t < 20.0) held_steady += held ? 1 : 0;
    if (t >= 20.0 && t < 22.5) held_ramp += held ? 1 : 0;
    if (t >= 30.0) {
      ++after;
      used_after += contains(r->estimate.used, 1) ? 1 : 0;
    }
  }
  EXPECT_EQ(held_steady, 0);
  EXPECT_GT(held_ramp, 0);
  EXPECT_NEAR(c->calibration(1).scale_x, 1.2, 0.01 * 1.2);
  EXPECT_GE(used_after, after * 98 / 100);
}

// The self-calibration's states are the consensus's: a sensor whose
// resolution is 27.5 % off (1020 cpi configured as 800; beyond the runaway
// bound of 25 %) is left out as `calibration`, a hypothesis of its own, and
// is still tested against each epoch's twist through its own calibration.
// Noise-free real-valued counts on mixed motion: once its estimate is there
// its corrected reading fits the twist (test ratio under 1: the estimate's
// error is far below the noise model's 2 % relative term), while its raw
// reading, 27.5 % off, would be rejected by a wide margin in every epoch
// that moves it (computed here from the noise model's own covariance, taken wider than it is).
TEST(SelfCalibration, ARunawayIsAHypothesisOfTheConsensusStillTestedThroughItsCalibration) {
  const SensorArray array = regular_polygon(4, 0.1, 0.0);
  auto built = self_calibrating_consensus(array);
  ASSERT_TRUE(std::holds_alternative<ConsensusEstimator>(built));
  ConsensusEstimator& consensus = std::get<ConsensusEstimator>(built);
  ASSERT_NE(consensus.self_calibration(), nullptr);
  const real dt = 0.01, off = 1020.0 / 800.0;
  int out_epochs = 0, fitting = 0, raw_rejected = 0;
  for (int e = 1; e <= 2000; ++e) {
    const double t = e * dt;
    const Twist2 x = test::mixed_motion(t);
    const ArraySample s = test::exact_sample(
        array, x, t, dt, [&](int i) -> Mat2 { return (i == 1 ? off : 1.0) * Mat2::Identity(); });
    const auto r = consensus.estimate(s);
    ASSERT_TRUE(r.has_value());
    for (int i : {0, 2, 3}) {
      EXPECT_NE(r->excluded[static_cast<std::size_t>(i)], Exclusion::kCalibration) << t;
    }
    if (r->excluded[1] != Exclusion::kCalibration) continue;
    ++out_epochs;
    EXPECT_FALSE(contains(r->estimate.used, 1)) << t;
    if (r->tests.sensor[1] <= 1.0) ++fitting;
    // The raw reading against the epoch's twist: residual (off - 1) times
    // the point velocity, its variance the noise model's relative term on
    // the reading plus one count of quantisation per axis.
    const Vec2 point = x.v + x.omega * Vec2(-array[1].position.y(), array[1].position.x());
    const real rel = ConsensusOptions{}.noise.relative * off * point.norm();
    const real q = 1.0 / (array[1].counts_per_metre() * dt);
    const real ratio = ((off - 1.0) * point).squaredNorm() / (rel * rel + q * q) /
                       chi2_quantile(1.0 - ConsensusOptions{}.alpha, 2);
    if (ratio > 1.0) ++raw_rejected;
  }
  const auto* c = consensus.self_calibration();
  EXPECT_TRUE(c->runaway(1));
  EXPECT_NEAR(std::sqrt(c->calibration(1).scale_x * c->calibration(1).scale_y), off, 0.01);
  // Out for most of the run (it runs away within a few seconds), fitting
  // through its calibration in nearly every epoch, its raw reading not.
  EXPECT_GT(out_epochs, 1000);
  EXPECT_GE(fitting, out_epochs * 99 / 100);
  EXPECT_GE(raw_rejected, out_epochs * 9 / 10);
}

// A calibration's reset (header, "Reset") is a hypothesis tested twice: the
// CUSUM of the rejected blocks alarms, and the blocks since it left zero must
// agree with one calibration. A sensor reading garbage (each epoch's counts
// through a random matrix) for 5 s is rejected block after block, so the
// CUSUM alarms, but its blocks agree with no calibration: never reset, and
// its estimate is where it was once the garbage ends. A sensor 40 % off on
// one axis alone (beyond the wide prior's reach of the sound one) is reset
// and its estimate ends within 1 % on each axis.
TEST(SelfCalibration, AGarbledSensorIsNotResetAFarOffCalibrationIs) {
  const SensorArray array = regular_polygon(4, 0.1, 0.0);
  const real dt = 0.01;
  std::mt19937 rng(7);
  std::uniform_real_distribution<real> entry(-1.5, 1.5);
  {
    auto built = self_calibrating_consensus(array);
    ASSERT_TRUE(std::holds_alternative<ConsensusEstimator>(built));
    ConsensusEstimator& consensus = std::get<ConsensusEstimator>(built);
    for (int e = 1; e <= 2000; ++e) {
      const double t = e * dt;
      const bool garbled = t > 5.0 && t <= 10.0;
      const ArraySample s = test::exact_sample(array, test::mixed_motion(t), t, dt, [&](int i) {
        Mat2 m = Mat2::Identity();
        if (i == 1 && garbled) m << entry(rng), entry(rng), entry(rng), entry(rng);
        return m;
      });
      ASSERT_TRUE(consensus.estimate(s).has_value());
    }
    const auto* c = consensus.self_calibration();
    EXPECT_EQ(c->resets(1), 0);
    EXPECT_FALSE(c->runaway(1));
    EXPECT_NEAR(c->calibration(1).scale_x, 1.0, 0.01);
    EXPECT_NEAR(c->calibration(1).scale_y, 1.0, 0.01);
  }
  {
    auto built = self_calibrating_consensus(array);
    ASSERT_TRUE(std::holds_alternative<ConsensusEstimator>(built));
    ConsensusEstimator& consensus = std::get<ConsensusEstimator>(built);
    // 1.4 times along the sensor's own x axis: C = R(yaw) diag(1.4, 1) R(yaw)^T
    // in the robot frame.
    const Mat2 r = rotation(array[1].yaw);
    const Mat2 off = r * Vec2(1.4, 1.0).asDiagonal() * r.transpose();
    for (int e = 1; e <= 2000; ++e) {
      const double t = e * dt;
      const ArraySample s = test::exact_sample(array, test::mixed_motion(t), t, dt, [&](int i) {
        return i == 1 ? off : Mat2(Mat2::Identity());
      });
      ASSERT_TRUE(consensus.estimate(s).has_value());
    }
    const auto* c = consensus.self_calibration();
    EXPECT_GE(c->resets(1), 1);
    EXPECT_NEAR(c->calibration(1).scale_x, 1.4, 0.014);
    EXPECT_NEAR(c->calibration(1).scale_y, 1.0, 0.01);
    EXPECT_TRUE(c->runaway(1));
    for (int i : {0, 2, 3}) EXPECT_EQ(c->resets(i), 0) << i;
  }
}

// faults-drift: m2's resolution falls by 10 % over 6 s. Its final scale is
// recovered within 2 % on both axes, and the error is not worse than
// without self-calibration beyond the paired bound.
TEST(SelfCalibration, RecoversADriftingSensorWithoutCostingPose) {
  std::vector<double> plain, calibrated;
  for (int seed = 101; seed <= 105; ++seed) {
    const PairedRun r = run_scenario("faults-drift", seed);
    plain.push_back(r.plain);
    calibrated.push_back(r.calibrated);
    ASSERT_TRUE(r.last.contains("m2")) << seed;
    EXPECT_NEAR(r.last.at("m2")[0], 0.9, 0.02 * 0.9) << seed;
    EXPECT_NEAR(r.last.at("m2")[1], 0.9, 0.02 * 0.9) << seed;
  }
  not_worse(calibrated, plain, "faults-drift: self-calibration vs none");
}

// A clean log (sekimori-a): self-calibration does no harm, every filter
// scale is within 4 of its printed sds of 1 (the sensors are built within
// 0.1 % of it, a small part of an sd: a filter whose covariance is honest
// is that far off in 6e-5 of its components), and what is applied (the
// file's scale_x, scale_y) is within 0.2 % of 1 (issue #15's third check).
TEST(SelfCalibration, DoesNoHarmOnACleanLog) {
  std::vector<double> plain, calibrated;
  for (int seed = 101; seed <= 105; ++seed) {
    const PairedRun r = run_scenario("sekimori-a", seed);
    plain.push_back(r.plain);
    calibrated.push_back(r.calibrated);
    // No calibration reset: its test alarms by chance at most once per hour
    // of driving a sensor (docs/math.md), these runs drive 4 x 17 s each.
    EXPECT_THAT(r.calibrated_err, Not(HasSubstr("was reset"))) << seed;
    for (const auto& [name, v] : r.last_filter) {
      const std::vector<double>& sd = r.last_sd.at(name);
      EXPECT_NEAR(v[0], 1.0, 4.0 * sd[0] + 0.001) << name << " seed " << seed;
      EXPECT_NEAR(v[1], 1.0, 4.0 * sd[1] + 0.001) << name << " seed " << seed;
    }
    for (const auto& [name, v] : r.last) {
      EXPECT_NEAR(v[0], 1.0, 0.002) << name << " seed " << seed;
      EXPECT_NEAR(v[1], 1.0, 0.002) << name << " seed " << seed;
    }
  }
  not_worse(calibrated, plain, "sekimori-a: self-calibration vs none");
}

// Issue #15's first check on faults-cruise (examples/scenarios/faults-cruise.yaml:
// m2's scale falls linearly to 0.9 over 90 s from 5 s, m3 repeats one frame's
// counts from 71 s to 74 s in a cruise, wheel slip random 0.05): with
// self-calibration the maximum error stays within 2 times that of the
// oracle (least squares over the sensors the simulator says are sound) on
// every seed (issue #27's bound for every fault case), m2's final scale is within 2 % of the
// simulated 0.9 on both axes, and it beats the estimate without self-calibration, which uses m2
// uncorrected until its drift is excluded.
TEST(SelfCalibration, DriftAndAFrozenRegisterInACruise) {
  std::vector<double> plain, calibrated;
  for (int seed = 101; seed <= 105; ++seed) {
    const PairedRun r = run_scenario("faults-cruise", seed, true);
    plain.push_back(r.plain);
    calibrated.push_back(r.calibrated);
    EXPECT_LE(r.calibrated, 2.0 * r.oracle) << seed;
    ASSERT_TRUE(r.last.contains("m2")) << seed;
    EXPECT_NEAR(r.last.at("m2")[0], 0.9, 0.02 * 0.9) << seed;
    EXPECT_NEAR(r.last.at("m2")[1], 0.9, 0.02 * 0.9) << seed;
  }
  // Better by a one-sided paired bound at 99 % (t = 3.747 on 5 seeds).
  const auto n = static_cast<double>(plain.size());
  double mean = 0.0, var = 0.0;
  for (std::size_t k = 0; k < plain.size(); ++k) mean += (plain[k] - calibrated[k]) / n;
  for (std::size_t k = 0; k < plain.size(); ++k) {
    var += (plain[k] - calibrated[k] - mean) * (plain[k] - calibrated[k] - mean) / (n - 1.0);
  }
  EXPECT_GT(mean - 3.747 * std::sqrt(var / n), 0.0) << "faults-cruise: self-calibration vs none";
}

// A register frozen in a cruise (faults-cruise's m3, one frame's counts
// repeated from 71 s to 74 s) reads what a good sensor would until the
// motion moves off it; then the drift test's alarm, never before its fewest
// epochs (h / (clip - k), test_robust.cpp), is named frozen by the repeats,
// and m3 stays out while they last, then for the release test's
// drift_release_time of fresh samples (the name kept) and no longer.
// Before the window m3 is never called frozen.
TEST(SelfCalibration, FrozenRegisterInACruiseIsNamedFrozenWhileItLasts) {
  for (int seed = 101; seed <= 103; ++seed) {
    const PairedRun r = run_scenario("faults-cruise", seed);
    ASSERT_FALSE(r.m3_frozen.empty()) << seed;
    // The row ending at 71.01 s is the first frozen one (frames whose
    // midpoint lies in [71, 74)).
    EXPECT_GE(r.m3_frozen.front(), 71.0 + 0.04) << seed;
    // Once named, out for every epoch to the release.
    const auto epochs = static_cast<double>(r.m3_frozen.size());
    EXPECT_NEAR(epochs, (r.m3_frozen.back() - r.m3_frozen.front()) / 0.01 + 1.0, 0.5) << seed;
    const double release = HealthOptions{}.drift_release_time;
    EXPECT_GE(r.m3_frozen.back(), 74.0 + release - 0.015) << seed;
    EXPECT_LE(r.m3_frozen.back(), 74.0 + 2.0 * release) << seed;
  }
}

// Not latched (issue #27): at selfcal-step's change of floor (m2's scale to
// 0.9 at 20 s) m2 is held out while its estimate moves, then comes back
// corrected and is judged like every sensor: from 10 s after the step to the
// end it is left out no more often than a sound sensor's false alarms allow
// (the consensus's alpha per epoch, its Poisson count bounded at about
// 4 sd), where a hold that latched kept it out to the end.
TEST(SelfCalibration, ASensorHeldAtAStepComesBackCorrected) {
  const real alpha = ConsensusOptions{}.alpha;
  for (int seed = 101; seed <= 103; ++seed) {
    const PairedRun r = run_scenario("selfcal-step", seed);
    // Excluded at the step (the health monitor's short window, then the hold).
    ASSERT_FALSE(r.m2_out.empty()) << seed;
    EXPECT_GE(r.m2_out.front(), 20.0) << seed;
    EXPECT_LE(r.m2_out.front(), 21.0) << seed;
    long late = 0;
    for (const double t : r.m2_out) late += t >= 30.0 ? 1 : 0;
    const long rows = r.epochs - 3000;  // 10 ms epochs from 30 s on
    ASSERT_GT(rows, 1000) << seed;
    const double mean = alpha * static_cast<double>(rows);
    EXPECT_LE(static_cast<double>(late), mean + 4.0 * std::sqrt(mean) + 3.0) << seed;
    // Corrected to the step's scale (2 %, as the experiment's test).
    ASSERT_TRUE(r.last.contains("m2")) << seed;
    EXPECT_NEAR(r.last.at("m2")[0], 0.9, 0.02 * 0.9) << seed;
  }
}

// Issue #15's second check on a clean log of the same path (cruise): no
// estimate passes the test that applies it, so the error is the same as
// without self-calibration (paired bound), every filter scale is within 4
// of its printed sds of 1 (as on sekimori-a above), and what is applied
// within 0.2 %.
TEST(SelfCalibration, DoesNoHarmOnACleanCruise) {
  std::vector<double> plain, calibrated;
  for (int seed = 101; seed <= 105; ++seed) {
    const PairedRun r = run_scenario("cruise", seed);
    plain.push_back(r.plain);
    calibrated.push_back(r.calibrated);
    for (const auto& [name, v] : r.last_filter) {
      const std::vector<double>& sd = r.last_sd.at(name);
      EXPECT_NEAR(v[0], 1.0, 4.0 * sd[0] + 0.001) << name << " seed " << seed;
      EXPECT_NEAR(v[1], 1.0, 4.0 * sd[1] + 0.001) << name << " seed " << seed;
    }
    for (const auto& [name, v] : r.last) {  // applied: issue #15's 0.2 %
      EXPECT_NEAR(v[0], 1.0, 0.002) << name << " seed " << seed;
      EXPECT_NEAR(v[1], 1.0, 0.002) << name << " seed " << seed;
    }
  }
  not_worse(calibrated, plain, "cruise: self-calibration vs none");
}

}  // namespace
}  // namespace moa
