// moa simulate -> moa calibrate -> robot.true.yaml: the issue's checks run
// end to end on logs of the simulator (not of the tests' synthesiser), each
// calibrated config compared with the simulated truth, within the issue's
// limits and within 5 of the 1-sigma the report gives.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <regex>
#include <string>
#include <vector>

#include "moa/core/se2.hpp"
#include "moa/formats/config.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa {
namespace {

namespace fs = std::filesystem;

constexpr double kDeg = std::numbers::pi / 180.0;
// The issue's limits: 0.5 mm, 0.2 deg, 0.3 %.
constexpr double kPositionLimit = 0.5e-3;
constexpr double kYawLimit = 0.2 * kDeg;
constexpr double kScaleLimit = 0.003;

test::RunResult simulate(const std::string& scenario, int seed, const fs::path& out) {
  return test::run_moa("simulate --scenario " + scenario + " --seed " + std::to_string(seed) +
                       " --out " + out.string());
}

// The 1-sigma of (px, py, yaw, sx, sy) per sensor, in order, from the JSON report.
std::vector<std::array<double, 5>> reported_sigma(const std::string& json) {
  static const std::regex sigma(
      R"re("sigma": \{"position": \[([^,\]]+), ([^\]]+)\], "yaw": ([^,]+), "scale": \[([^,\]]+), ([^\]]+)\]\})re");
  std::vector<std::array<double, 5>> out;
  for (auto it = std::sregex_iterator(json.begin(), json.end(), sigma);
       it != std::sregex_iterator(); ++it) {
    std::array<double, 5> s{};
    for (std::size_t p = 0; p < 5; ++p) s[p] = std::stod((*it)[static_cast<int>(p) + 1].str());
    out.push_back(s);
  }
  return out;
}

// Every sensor of `cal` against `truth`: within the issue's limits, within
// 5 sigma, mirroring right.
void expect_within_limits_and_sigma(const io::RobotConfig& cal, const io::RobotConfig& truth,
                                    const std::vector<std::array<double, 5>>& sigma) {
  ASSERT_EQ(cal.names, truth.names);
  ASSERT_EQ(sigma.size(), cal.names.size());
  for (int i = 0; i < cal.array.size(); ++i) {
    const auto u = static_cast<std::size_t>(i);
    const SensorMount& c = cal.array[i];
    const SensorMount& t = truth.array[i];
    const std::array<double, 5> error{
        std::abs(c.position.x() - t.position.x()), std::abs(c.position.y() - t.position.y()),
        std::abs(wrap_angle(c.yaw - t.yaw)), std::abs(c.scale.x() - t.scale.x()),
        std::abs(c.scale.y() - t.scale.y())};
    const std::array<double, 5> limit{kPositionLimit, kPositionLimit, kYawLimit, kScaleLimit,
                                      kScaleLimit};
    for (std::size_t p = 0; p < 5; ++p) {
      EXPECT_LT(error[p], limit[p]) << cal.names[u] << " parameter " << p;
      EXPECT_LT(error[p], 5.0 * sigma[u][p]) << cal.names[u] << " parameter " << p;
    }
    EXPECT_EQ(c.mirrored, t.mirrored) << cal.names[u];
    EXPECT_EQ(c.cpi, t.cpi) << cal.names[u];
  }
}

TEST(CalibrateSimulated, PapersExampleGivesEquation53AndTheTruePositions) {
  const fs::path dir = test::scratch_dir("cal-sim-kimlee");
  ASSERT_EQ(simulate("kimlee", 5, dir).exit_code, 0);
  const std::string base = "calibrate --config " + (dir / "robot.yaml").string() + " --log " +
                           dir.string() + " --out " + (dir / "cal.yaml").string() + " --method ";

  // Kim & Lee's eq. (53), in units of r = 0.3 m, to the paper's three digits.
  const auto k = test::run_moa(base + "kimlee");
  ASSERT_EQ(k.exit_code, 0) << k.err;
  const std::array<double, 6> eq53{0.912, -0.526, 0.000, 1.053, -0.912, -0.526};
  const io::RobotConfig kl = io::read_config(dir / "cal.yaml");
  for (int i = 0; i < 3; ++i) {
    for (int a = 0; a < 2; ++a) {
      EXPECT_NEAR(kl.array[i].position(a) / 0.3, eq53[static_cast<std::size_t>(2 * i + a)], 0.002)
          << kl.names[static_cast<std::size_t>(i)];
    }
  }

  const auto e = test::run_moa(base + "exact");
  ASSERT_EQ(e.exit_code, 0) << e.err;
  const io::RobotConfig ex = io::read_config(dir / "cal.yaml");
  const io::RobotConfig truth = io::read_config(dir / "robot.true.yaml");
  for (int i = 0; i < 3; ++i) {
    EXPECT_LT((ex.array[i].position - truth.array[i].position).norm(), kPositionLimit)
        << ex.names[static_cast<std::size_t>(i)];
  }
  fs::remove_all(dir);
}

TEST(CalibrateSimulated, ExactMeetsTheLimitsOnTheCalibrationScenario) {
  // Four sensors up to 8 mm, 4 deg, 4 % off, one mirrored; 40 s of mixed
  // motion; reference noise 5 mm/s and 0.02 rad/s per 10 ms row.
  const fs::path dir = test::scratch_dir("cal-sim-exact");
  ASSERT_EQ(simulate("calibration", 11, dir).exit_code, 0);
  const auto r =
      test::run_moa("calibrate --config " + (dir / "robot.yaml").string() + " --log " +
                    dir.string() + " --method exact --json --out " + (dir / "cal.yaml").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  expect_within_limits_and_sigma(io::read_config(dir / "cal.yaml"),
                                 io::read_config(dir / "robot.true.yaml"), reported_sigma(r.out));
  fs::remove_all(dir);
}

// A robot other than the built-in scenario's: a rectangle, errors at the
// issue's limits (8 mm, 4 deg, 4 %), the last sensor mirrored, noisier
// counts; moved by one scripted twist per recording.
std::string guided_scenario(const std::string& name, const std::string& twist, double duration) {
  return "version: 1\nname: " + name +
         "\n"
         "sensor_model: {preset: ADNS-3080, packets_per_row: 32, frame_noise: 0.08, "
         "relative_noise: 0.02}\n"
         "sensors:\n"
         "  - {name: fl, position: [0.12, 0.08], yaw: 0.0}\n"
         "  - {name: fr, position: [0.12, -0.08], yaw: 1.5707963267948966}\n"
         "  - {name: rl, position: [-0.12, 0.08], yaw: 3.141592653589793}\n"
         "  - {name: rr, position: [-0.12, -0.08], yaw: 4.71238898038469}\n"
         "true_sensors:\n"
         "  fl: {position_error: [-0.008, 0.008], yaw_error: -0.0698, scale: [0.96, 1.04]}\n"
         "  fr: {position_error: [0.008, -0.0075], yaw_error: 0.0698, scale: [1.04, 0.96]}\n"
         "  rl: {position_error: [0.0, -0.008], yaw_error: 0.0349, scale: [1.0, 1.04]}\n"
         "  rr: {position_error: [-0.007, 0.008], yaw_error: -0.0698, scale: [0.96, 0.97], "
         "mirrored: true}\n"
         "motion:\n"
         "  type: twists\n"
         "  max_accel: 0.5\n"
         "  max_angular_accel: 10\n"
         "  segments:\n"
         "    - {twist: [0, 0, 0], duration: 0.5}\n"
         "    - {twist: " +
         twist + ", duration: " + std::to_string(duration) +
         "}\n"
         "    - {twist: [0, 0, 0], duration: 0.5}\n";
}

TEST(CalibrateSimulated, GuidedMeetsTheLimitsFromTwoPushesAndFiveTurns) {
  // 1 m along x and along y at 0.25 m/s, 5 turns at pi rad/s; the ramps of
  // the acceleration limits are symmetric, so the totals are exact.
  const fs::path dir = test::scratch_dir("cal-sim-guided");
  const std::array<std::array<std::string, 2>, 3> recordings{
      {{"push-x", "[0.25, 0, 0]"},
       {"push-y", "[0, 0.25, 0]"},
       {"spin", "[0, 0, 3.141592653589793]"}}};
  for (const auto& [name, twist] : recordings) {
    const fs::path scenario = dir / (name + ".yaml");
    std::ofstream(scenario) << guided_scenario(name, twist, name == "spin" ? 10.0 : 4.0);
    ASSERT_EQ(simulate(scenario.string(), 3, dir / name).exit_code, 0) << name;
  }
  const auto r =
      test::run_moa("calibrate --config " + (dir / "push-x" / "robot.yaml").string() +
                    " --method guided" + " --push-x " + (dir / "push-x").string() + " --push-y " +
                    (dir / "push-y").string() + " --spin " + (dir / "spin").string() +
                    " --distance 1 --turns 5 --json --out " + (dir / "cal.yaml").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::RobotConfig cal = io::read_config(dir / "cal.yaml");
  expect_within_limits_and_sigma(cal, io::read_config(dir / "push-x" / "robot.true.yaml"),
                                 reported_sigma(r.out));
  // The config's 270 deg comes back as about 266 deg, not -94 deg.
  EXPECT_NEAR(cal.array[3].yaw, 4.71238898038469 - 0.0698, 0.2 * kDeg);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace moa
