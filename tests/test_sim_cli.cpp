// moa simulate end to end: the files of log format v1, the configs, the
// same bytes for the same seed, and the issue's own check: an independent
// implementation of the measurement model applied to truth.csv and
// robot.true.yaml gives each sensor's total counts.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "moa/formats/config.hpp"
#include "moa/formats/log.hpp"
#include "support/run.hpp"
#include "support/slow.hpp"
#include "support/synth.hpp"

namespace moa {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

const std::vector<std::string> kFiles = {"mice.csv",   "wheels.csv", "camera.csv",     "truth.csv",
                                         "faults.csv", "robot.yaml", "robot.true.yaml"};

test::RunResult simulate(const std::string& scenario, int seed, const fs::path& out) {
  return test::run_moa("simulate --scenario " + scenario + " --seed " + std::to_string(seed) +
                       " --out " + out.string());
}

TEST(SimCli, WritesALogTheReadersAccept) {
  const auto dir = test::scratch_dir("sim-cli") / "b";
  const auto r = simulate("sekimori-b", 1, dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr(dir.string()));
  for (const auto& f : kFiles) EXPECT_TRUE(fs::exists(dir / f)) << f;

  const io::RobotConfig config = io::read_config(dir / "robot.yaml");
  io::MiceReader mice(dir, config);
  std::size_t rows = 0;
  while (mice.next()) ++rows;
  EXPECT_EQ(rows % 4, 0u);
  EXPECT_THAT(r.out, HasSubstr(std::to_string(rows) + " mice rows"));
  EXPECT_GT(io::read_all<io::WheelRow>(dir / "wheels.csv").size(), 1000u);
  EXPECT_GT(io::read_all<io::CameraRow>(dir / "camera.csv").size(), 100u);
  const auto truth = io::read_all<io::TruthRow>(dir / "truth.csv");
  // >= 100 Hz.
  for (std::size_t i = 1; i < truth.size(); ++i) {
    ASSERT_LE(truth[i].t - truth[i - 1].t, 0.01 + 1e-12);
  }
  // Table 3 ends at (1.5 m, 1.0 m, 0), and the file says so exactly.
  EXPECT_EQ(truth.back().pose.t.x(), 1.5);
  EXPECT_EQ(truth.back().pose.t.y(), 1.0);
  EXPECT_EQ(truth.back().pose.theta, 0.0);
}

TEST(SimCli, SameSeedSameBytesOtherSeedOtherData) {
  const auto root = test::scratch_dir("sim-seed");
  ASSERT_EQ(simulate("sekimori-b", 7, root / "one").exit_code, 0);
  ASSERT_EQ(simulate("sekimori-b", 7, root / "two").exit_code, 0);
  ASSERT_EQ(simulate("sekimori-b", 8, root / "three").exit_code, 0);
  for (const auto& f : kFiles) {
    EXPECT_EQ(slurp(root / "one" / f), slurp(root / "two" / f)) << f;
  }
  EXPECT_NE(slurp(root / "one" / "mice.csv"), slurp(root / "three" / "mice.csv"));
  EXPECT_NE(slurp(root / "one" / "wheels.csv"), slurp(root / "three" / "wheels.csv"));
  // The path and the robot do not depend on the seed.
  EXPECT_EQ(slurp(root / "one" / "robot.true.yaml"), slurp(root / "three" / "robot.true.yaml"));
}

// docs/formats/config.md applied to the truth: for each pair of consecutive truth
// poses the body-frame motion (v dt, omega dt) from the SE(2) logarithm,
// then counts = k diag(scale) F R(yaw)^T (v dt + omega dt J p).
std::map<std::string, Eigen::Vector2d> model_totals(const fs::path& dir) {
  const io::RobotConfig truth_config = io::read_config(dir / "robot.true.yaml");
  const auto truth = io::read_all<io::TruthRow>(dir / "truth.csv");
  std::map<std::string, Eigen::Vector2d> totals;
  for (const auto& n : truth_config.names) totals[n] = Eigen::Vector2d::Zero();
  for (std::size_t i = 1; i < truth.size(); ++i) {
    const Pose2& a = truth[i - 1].pose;
    const Pose2& b = truth[i].pose;
    const double phi = b.theta - a.theta;
    const double c0 = std::cos(a.theta), s0 = std::sin(a.theta);
    const Eigen::Vector2d d(c0 * (b.t.x() - a.t.x()) + s0 * (b.t.y() - a.t.y()),
                            -s0 * (b.t.x() - a.t.x()) + c0 * (b.t.y() - a.t.y()));
    Eigen::Vector2d v = d;  // v dt
    if (std::abs(phi) > 1e-9) {
      const double s = std::sin(phi) / phi, c = (1.0 - std::cos(phi)) / phi;
      v = Eigen::Vector2d(s * d.x() + c * d.y(), -c * d.x() + s * d.y()) / (s * s + c * c);
    }
    for (int k = 0; k < truth_config.array.size(); ++k) {
      const SensorMount& m = truth_config.array[k];
      const Eigen::Vector2d u(v.x() - phi * m.position.y(), v.y() + phi * m.position.x());
      const double cy = std::cos(m.yaw), sy = std::sin(m.yaw);
      double wx = cy * u.x() + sy * u.y();
      double wy = -sy * u.x() + cy * u.y();
      if (m.mirrored) wy = -wy;
      const double kk = m.cpi / 0.0254;
      totals[truth_config.names[static_cast<std::size_t>(k)]] +=
          Eigen::Vector2d(kk * m.scale.x() * wx, kk * m.scale.y() * wy);
    }
  }
  return totals;
}

TEST(SimCli, CountTotalsFollowTheTruthThroughAnIndependentModel) {
  // The check on sekimori-a seed 1: within 2 % for at least three
  // of the four sensors. Speed (a) is under the rating, so all four hold.
  const auto dir = test::scratch_dir("sim-model") / "a";
  ASSERT_EQ(simulate("sekimori-a", 1, dir).exit_code, 0);
  const auto expected = model_totals(dir);
  std::map<std::string, Eigen::Vector2d> totals;
  std::ifstream mice(dir / "mice.csv");
  std::string line;
  while (std::getline(mice, line)) {
    if (line.empty() || line[0] == '#' || line[0] == 't') continue;
    std::stringstream fields(line);
    std::string t, name, dx, dy;
    std::getline(fields, t, ',');
    std::getline(fields, name, ',');
    std::getline(fields, dx, ',');
    std::getline(fields, dy, ',');
    if (!totals.contains(name)) totals[name] = Eigen::Vector2d::Zero();
    totals[name] += Eigen::Vector2d(std::stod(dx), std::stod(dy));
  }
  ASSERT_EQ(totals.size(), 4u);
  for (const auto& [name, total] : totals) {
    const Eigen::Vector2d e = expected.at(name);
    EXPECT_GT(e.cwiseAbs().minCoeff(), 5e4) << name;  // 2.5 m travelled: large totals
    for (int a = 0; a < 2; ++a) {
      EXPECT_NEAR(total[a], e[a], 0.02 * std::abs(e[a])) << name << " axis " << a;
    }
  }
}

TEST(SimCli, EstimatorGetsTheTruthBackWithTheTrueConfig) {
  // The simulator and the estimator share the measurement model: with the
  // true config, least squares on the fault-free run (a) is off only by
  // noise. Noise: ~1e-3 m/s per sensor and row, so a heading random walk
  // of ~2e-3 rad and ~2 mm over the 17 s run; bounds are 5 times those.
  const auto dir = test::scratch_dir("sim-odometry") / "a";
  ASSERT_EQ(simulate("sekimori-a", 2, dir).exit_code, 0);
  const auto odo =
      test::run_moa("odometry --config " + (dir / "robot.true.yaml").string() + " --log " +
                    dir.string() + " --estimator ls --out " + (dir / "odometry.csv").string());
  ASSERT_EQ(odo.exit_code, 0) << odo.err;
  const auto ev = test::run_moa("evaluate --json --truth " + (dir / "truth.csv").string() +
                                " --odometry " + (dir / "odometry.csv").string());
  ASSERT_EQ(ev.exit_code, 0) << ev.err;
  const auto number = [&](const std::string& key) {
    const auto at = ev.out.find("\"" + key + "\": ");
    return std::stod(ev.out.substr(at + key.size() + 4));
  };
  EXPECT_LT(number("max_translation_m"), 0.01);
  EXPECT_LT(number("max_heading_rad"), 0.01);
}

TEST(SimCli, UnknownScenarioIsAnErrorAndWritesNothing) {
  const auto dir = test::scratch_dir("sim-bad") / "out";
  const auto r = simulate("sekimori-c", 1, dir);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(
      r.err,
      HasSubstr("scenario 'sekimori-c': not a built-in scenario (calib-camera, "
                "calib-mocap, calibration, "
                "cruise, differential, faults-bump, faults-cruise, faults-dirty, "
                "faults-drift, faults-floor, faults-liftoff, faults-runaway, faults-spikes, "
                "faults-stuck, faults-zero, guided, gyro-bump, gyro-bump-quiet, gyro-compact, "
                "gyro-one, gyro-papers, kimlee, sekimori-a, "
                "sekimori-b, "
                "selfcal-ramp, selfcal-step, speed-scale) and no "
                "such file"));
  EXPECT_FALSE(fs::exists(dir));
}

TEST(SimCli, BadScenarioFileIsReportedWithItsLine) {
  const auto dir = test::scratch_dir("sim-badfile");
  std::ofstream(dir / "s.yaml") << "version: 1\nname: x\nsensor_model: {preset: HDNS-2051}\n"
                                   "sensors: {layout: radial, angles_deg: [0, 90], distance: 0.1}\n"
                                   "motion: {type: twists, segments: [{twist: [1, 0, 0], "
                                   "duration: -1}]}\n";
  const auto r = simulate((dir / "s.yaml").string(), 1, dir / "out");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr((dir / "s.yaml").string() +
                               ":5: key 'motion.segments[0].duration': must be > 0 (found -1)"));
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST(SimCli, OutputThatIsAFileIsAnError) {
  const auto dir = test::scratch_dir("sim-file");
  std::ofstream(dir / "taken") << "x";
  const auto r = simulate("kimlee", 1, dir / "taken");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "moa simulate: error: " + (dir / "taken").string() +
                       ": exists and is not a directory\n");
}

std::vector<std::string> entries(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

TEST(SimCli, APreviousRunIsReplacedWholeNeverMixed) {
  // sekimori-b has a camera, calibration has none: its camera.csv must not survive.
  const auto root = test::scratch_dir("sim-replace");
  ASSERT_EQ(simulate("sekimori-b", 1, root / "run").exit_code, 0);
  ASSERT_TRUE(fs::exists(root / "run" / "camera.csv"));
  const auto r = simulate("calibration", 1, root / "run");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(entries(root / "run"),
            (std::vector<std::string>{"faults.csv", "faults.json", "mice.csv", "robot.true.yaml",
                                      "robot.yaml", "truth.csv", "wheels.csv"}));
  EXPECT_THAT(slurp(root / "run" / "mice.csv"), HasSubstr("scenario 'calibration'"));
  // Nothing else beside it: no temporary directory left.
  EXPECT_EQ(entries(root), std::vector<std::string>{"run"});
}

TEST(SimCli, ADirectoryWithOtherFilesIsRefusedAndKept) {
  const auto root = test::scratch_dir("sim-foreign");
  ASSERT_EQ(simulate("sekimori-b", 1, root / "run").exit_code, 0);
  std::ofstream(root / "run" / "odometry.csv") << "mine\n";
  const std::string before = slurp(root / "run" / "mice.csv");
  const auto r = simulate("calibration", 1, root / "run");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "moa simulate: error: " + (root / "run").string() +
                       ": not empty and not a log written by moa simulate ('odometry.csv'); give "
                       "an empty or new directory\n");
  EXPECT_EQ(slurp(root / "run" / "mice.csv"), before);
  EXPECT_EQ(slurp(root / "run" / "odometry.csv"), "mine\n");
  EXPECT_EQ(entries(root), std::vector<std::string>{"run"});
}

TEST(SimCli, AnEmptyDirectoryIsWrittenInto) {
  const auto root = test::scratch_dir("sim-empty");
  fs::create_directories(root / "run");
  ASSERT_EQ(simulate("kimlee", 1, root / "run").exit_code, 0);
  EXPECT_TRUE(fs::exists(root / "run" / "mice.csv"));
  EXPECT_EQ(entries(root), std::vector<std::string>{"run"});
}

TEST(SimCli, SeedsThatAreNotWholeNumbersAreRefused) {
  // CLI11 alone turned both into 18446744073709551615.
  const auto dir = test::scratch_dir("sim-seed-bad");
  for (const std::string seed : {"-1", "1e23", "18446744073709551616", "1.5"}) {
    const auto r = test::run_moa("simulate --scenario kimlee --seed " + seed + " --out " +
                                 (dir / "out").string());
    EXPECT_EQ(r.exit_code, 2) << seed;  // a usage error
    EXPECT_EQ(r.err, "--seed: '" + seed +
                         "' is not a whole number from 0 to 18446744073709551615\nRun with --help "
                         "for more information.\n");
    EXPECT_FALSE(fs::exists(dir / "out")) << seed;
  }
  const auto r = test::run_moa("simulate --scenario kimlee --seed 18446744073709551615 --out " +
                               (dir / "out").string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("seed 18446744073709551615"));
}

// A scenario simulated into DIR/log and calibrated against its camera into
// DIR/cal.yaml; DIR returned.
fs::path simulate_and_calibrate(const std::string& scenario, int seed) {
  const fs::path dir = test::scratch_dir("sim-" + scenario);
  const auto sim = simulate(scenario, seed, dir / "log");
  [&] { ASSERT_EQ(sim.exit_code, 0) << sim.err; }();
  if (::testing::Test::HasFatalFailure()) return dir;
  const auto cal =
      test::run_moa("calibrate --config " + (dir / "log/robot.yaml").string() + " --log " +
                    (dir / "log").string() + " --method exact --reference camera --out " +
                    (dir / "cal.yaml").string());
  [&] { ASSERT_EQ(cal.exit_code, 0) << cal.err; }();
  return dir;
}

// calib-mocap end to end: moa calibrate --method exact --reference camera
// recovers robot.true.yaml's mounts and latencies (sensors and camera, up to
// the gauge: the sensors' mean latency, 0 in robot.yaml) within 4 x the
// 1-sigma it reports on this log (0.15 mm, 0.026 deg, 0.05 %, 0.04 ms per
// sensor, 0.17 ms for the camera; docs/calibration.md).
TEST(SimCli, CalibMocapCalibratesBackToItsTrueRobot) {
  const fs::path dir = simulate_and_calibrate("calib-mocap", 5);
  if (HasFatalFailure()) return;
  const io::RobotConfig got = io::read_config(dir / "cal.yaml");
  const io::RobotConfig truth = io::read_config(dir / "log/robot.true.yaml");
  ASSERT_EQ(got.array.size(), 4);
  double got_mean = 0.0;
  double true_mean = 0.0;
  for (int i = 0; i < 4; ++i) {
    got_mean += got.array[i].latency / 4.0;
    true_mean += truth.array[i].latency / 4.0;
  }
  for (int i = 0; i < 4; ++i) {
    const SensorMount& g = got.array[i];
    const SensorMount& t = truth.array[i];
    EXPECT_LT((g.position - t.position).cwiseAbs().maxCoeff(), 4 * 0.15e-3) << i;
    EXPECT_LT(std::abs(std::remainder(g.yaw - t.yaw, 2 * std::numbers::pi)),
              4 * 0.026 * std::numbers::pi / 180)
        << i;
    EXPECT_LT((g.scale - t.scale).cwiseAbs().maxCoeff(), 4 * 0.0005) << i;
    EXPECT_EQ(g.mirrored, t.mirrored) << i;
    EXPECT_NEAR(g.latency - got_mean, t.latency - true_mean, 4 * 0.04e-3) << i;
  }
  ASSERT_TRUE(got.camera_latency.has_value());
  ASSERT_TRUE(truth.camera_latency.has_value());
  EXPECT_NEAR(*got.camera_latency - got_mean, *truth.camera_latency - true_mean, 4 * 0.17e-3);
}

// The ceiling-camera limits on `calib-camera` (positions only at
// 25 Hz, 2 mm, 60 ms late, jitter, drops): positions 2 mm, yaw (in the
// gauge's frame: the truth turned back by its mean yaw change over the
// sensors whose mirroring is nominal) 0.25 deg, scale 0.5 %, relative sensor
// latencies 2 ms, the camera's 3 ms. Seed 5 (seeds 1-10 in docs/calibration.md).
TEST(SimCli, CalibCameraCalibratesBackToItsTrueRobotInTheGauge) {
  MOA_SKIP_UNDER_SANITIZER("a 60 s ceiling-camera calibration");
  const fs::path dir = simulate_and_calibrate("calib-camera", 5);
  if (HasFatalFailure()) return;
  const io::RobotConfig got = io::read_config(dir / "cal.yaml");
  const io::RobotConfig truth = io::read_config(dir / "log/robot.true.yaml");
  const io::RobotConfig nominal = io::read_config(dir / "log/robot.yaml");
  ASSERT_EQ(got.array.size(), 4);
  double got_mean = 0.0, true_mean = 0.0, sn = 0.0, cs = 0.0;
  for (int i = 0; i < 4; ++i) {
    got_mean += got.array[i].latency / 4.0;
    true_mean += truth.array[i].latency / 4.0;
    if (truth.array[i].mirrored != nominal.array[i].mirrored) continue;
    sn += std::sin(truth.array[i].yaw - nominal.array[i].yaw);
    cs += std::cos(truth.array[i].yaw - nominal.array[i].yaw);
  }
  const double delta = std::atan2(sn, cs);
  for (int i = 0; i < 4; ++i) {
    const SensorMount& g = got.array[i];
    const SensorMount& t = truth.array[i];
    EXPECT_LT((g.position - rotation(-delta) * t.position).norm(), 2e-3) << i;
    EXPECT_LT(std::abs(std::remainder(g.yaw - (t.yaw - delta), 2 * std::numbers::pi)),
              0.25 * std::numbers::pi / 180)
        << i;
    EXPECT_LT((g.scale - t.scale).cwiseAbs().maxCoeff(), 0.005) << i;
    EXPECT_EQ(g.mirrored, t.mirrored) << i;
    EXPECT_NEAR(g.latency - got_mean, t.latency - true_mean, 2e-3) << i;
  }
  ASSERT_TRUE(got.camera_latency.has_value());
  EXPECT_NEAR(*got.camera_latency - got_mean, *truth.camera_latency - true_mean, 3e-3);
}

}  // namespace
}  // namespace moa
