// moa calibrate and moa experiment end to end: logs on disk in, a config
// v1 out, the report, and every bad input with its precise error.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <regex>
#include <string>

#include "moa/formats/config.hpp"
#include "support/calibration_data.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

const std::vector<std::string> kNames{"a", "b", "c", "d"};

// A log of `truth` moving by `script`: mice.csv (integer counts, 100 Hz
// rows), wheels.csv (the average twist per row plus noise), and the
// nominal config as nominal.yaml.
fs::path write_reference_log(const std::string& tag, const SensorArray& nominal,
                             const SensorArray& truth, const test::TwistScript& script,
                             double duration, double period, test::ReferenceNoise noise,
                             const std::vector<std::string>& names = kNames) {
  const fs::path dir = test::scratch_dir(tag);
  const test::SynthLog log = test::synthesise(truth, script, duration, period, true, period / 8);
  test::write_log(log, truth, names, dir);
  test::write_wheels(dir, script, duration, period, noise, 7, period / 8);
  io::RobotConfig config;
  config.names = names;
  config.array = nominal;
  io::write_config(config, dir / "nominal.yaml");
  return dir;
}

std::string calibrate_args(const fs::path& dir, const std::string& method) {
  return "calibrate --config " + (dir / "nominal.yaml").string() + " --log " + dir.string() +
         " --method " + method + " --out " + (dir / "cal.yaml").string();
}

void expect_one_line_error(const test::RunResult& r, const std::string& what) {
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, HasSubstr(what));
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

// The check's robot: errors up to 8 mm, 4 deg, 4 % and one sensor mirrored,
// mixed motion for 20 s, reference noise 5 mm/s and 0.02 rad/s per 10 ms row.
struct CheckRobot {
  SensorArray nominal = test::four_sensor_nominal();
  SensorArray truth;
  fs::path dir;
  explicit CheckRobot(const std::string& tag) {
    std::mt19937_64 rng(31);
    truth = test::perturbed(nominal, rng, 0.008, 4.0 * std::numbers::pi / 180.0, 0.04, 1);
    dir = write_reference_log(tag, nominal, truth, test::mixed_motion, 20.0, 0.01, {0.005, 0.02});
  }
};

TEST(CalibrateCli, ExactMeetsTheLimitsOnNoisyMixedMotion) {
  // The method's 1-sigma here is ~0.1 mm, 0.02 deg, 0.04 %, so the check's
  // 0.5 mm, 0.2 deg, 0.3 % hold with wide margins.
  const CheckRobot robot("cal-exact");
  const SensorArray& nominal = robot.nominal;
  const SensorArray& truth = robot.truth;
  const fs::path& dir = robot.dir;
  const auto r = test::run_moa(calibrate_args(dir, "exact"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("b: mirrored in the data but not in the nominal config"));
  EXPECT_THAT(r.out, HasSubstr("every parameter of every sensor excited"));
  const io::RobotConfig cal = io::read_config(dir / "cal.yaml");
  ASSERT_EQ(cal.names, kNames);
  for (int i = 0; i < 4; ++i) {
    const SensorMount& m = cal.array[i];
    EXPECT_LT((m.position - truth[i].position).cwiseAbs().maxCoeff(), 0.5e-3) << kNames[i];
    EXPECT_LT(std::abs(wrap_angle(m.yaw - truth[i].yaw)), 0.2 * std::numbers::pi / 180.0)
        << kNames[i];
    EXPECT_LT((m.scale - truth[i].scale).cwiseAbs().maxCoeff(), 0.003) << kNames[i];
    EXPECT_EQ(m.mirrored, truth[i].mirrored) << kNames[i];
    EXPECT_EQ(m.cpi, nominal[i].cpi);
  }
  fs::remove_all(dir);
}

// camera.csv (t,x,y,theta) of a synthesised log's truth, the fixes at its
// row times, stamped `late` s after capture.
// With `positions_only`, a ceiling camera's t,x,y every fourth row (25 Hz).
void write_camera(const fs::path& dir, const SensorArray& truth, double duration, double late,
                  bool positions_only = false) {
  const test::SynthLog log = test::synthesise(truth, test::mixed_motion, duration, 0.01);
  std::ofstream camera(dir / "camera.csv");
  camera.precision(9);
  camera << (positions_only ? "t,x,y\n" : "t,x,y,theta\n");
  for (std::size_t k = 0; k < log.truth.size(); ++k) {
    const auto& p = log.truth[k];
    if (positions_only && k % 4 != 0) continue;
    camera << p.t + late << "," << p.pose.t.x() << "," << p.pose.t.y();
    if (!positions_only) camera << "," << wrap_angle(p.pose.theta);
    camera << "\n";
  }
}

TEST(CalibrateCli, ExactAgainstTheCameraWritesMountsAndLatencies) {
  // Poses exact, stamped 40 ms late; no wheels.csv: the camera is the default.
  const CheckRobot robot("cal-camera");
  fs::remove(robot.dir / "wheels.csv");
  write_camera(robot.dir, robot.truth, 20.0, 0.04);
  const auto r = test::run_moa(calibrate_args(robot.dir, "exact"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("coarse alignment: camera latency"));
  const io::RobotConfig cal = io::read_config(robot.dir / "cal.yaml");
  ASSERT_TRUE(cal.camera_latency.has_value());
  // The sensors' rows are on time (latency 0, the gauge): each within 4 of
  // the sigmas the report prints (0.05-0.08 ms: the counts' quantisation;
  // a fixed 0.1 ms failed at 1.5 sigma built with clang).
  EXPECT_NEAR(*cal.camera_latency, 0.04, 1e-4);
  for (int i = 0; i < 4; ++i) {
    EXPECT_LT((cal.array[i].position - robot.truth[i].position).cwiseAbs().maxCoeff(), 0.3e-3)
        << kNames[i];
    std::smatch m;
    const std::regex printed(std::string(" ") + kNames[i] + " (-?[0-9.]+) \\+- ([0-9.]+) ms");
    ASSERT_TRUE(std::regex_search(r.out, m, printed)) << kNames[i] << "\n" << r.out;
    const double sigma = std::max(std::stod(m[2].str()), 0.01) * 1e-3;  // printed to 0.01 ms
    EXPECT_NEAR(std::stod(m[1].str()) * 1e-3, cal.array[i].latency, 0.005e-3) << kNames[i];
    EXPECT_LT(std::abs(cal.array[i].latency), 4.0 * sigma) << kNames[i] << "\n" << r.out;
    EXPECT_EQ(cal.array[i].mirrored, robot.truth[i].mirrored) << kNames[i];
  }
  fs::remove_all(robot.dir);
}

TEST(CalibrateCli, ExactAgainstACeilingCameraKeepsTheMeanYawAsItsGauge) {
  // Positions only at 25 Hz, exact, 60 ms late: the robot frame's
  // orientation is not seen, the sensors' mean yaw stays nominal and the
  // rest is compared in that frame (the truth turned by its mean yaw change).
  const CheckRobot robot("cal-ceiling");
  fs::remove(robot.dir / "wheels.csv");
  write_camera(robot.dir, robot.truth, 20.0, 0.06, true);
  const auto r = test::run_moa(calibrate_args(robot.dir, "exact"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("positions only"));
  EXPECT_THAT(r.out, HasSubstr("gauge: the robot frame's orientation is not seen"));
  const io::RobotConfig cal = io::read_config(robot.dir / "cal.yaml");
  ASSERT_TRUE(cal.camera_latency.has_value());
  EXPECT_NEAR(*cal.camera_latency, 0.06, 1e-3);
  // The gauge's mean is over the sensors whose mirroring the data kept (b's
  // flip changes what its yaw means).
  double sn = 0.0, cs = 0.0, sn_cal = 0.0, cs_cal = 0.0;
  for (int i = 0; i < 4; ++i) {
    if (robot.truth[i].mirrored != robot.nominal[i].mirrored) continue;
    sn += std::sin(wrap_angle(robot.truth[i].yaw - robot.nominal[i].yaw));
    cs += std::cos(wrap_angle(robot.truth[i].yaw - robot.nominal[i].yaw));
    sn_cal += std::sin(wrap_angle(cal.array[i].yaw - robot.nominal[i].yaw));
    cs_cal += std::cos(wrap_angle(cal.array[i].yaw - robot.nominal[i].yaw));
  }
  EXPECT_NEAR(std::atan2(sn_cal, cs_cal), 0.0, 1e-6);
  const double delta = std::atan2(sn, cs);
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector2d p = rotation(-delta) * robot.truth[i].position;
    EXPECT_LT((cal.array[i].position - p).cwiseAbs().maxCoeff(), 1e-3) << kNames[i];
    EXPECT_LT(std::abs(wrap_angle(cal.array[i].yaw - (robot.truth[i].yaw - delta))),
              0.1 * std::numbers::pi / 180.0)
        << kNames[i];
    EXPECT_EQ(cal.array[i].mirrored, robot.truth[i].mirrored) << kNames[i];
  }
  const auto json = test::run_moa(calibrate_args(robot.dir, "exact") + " --json");
  ASSERT_EQ(json.exit_code, 0) << json.err;
  EXPECT_THAT(json.out, HasSubstr("\"positions_only\": true"));
  EXPECT_THAT(json.out, HasSubstr("\"yaw_gauge_rad\""));
  EXPECT_THAT(json.out, HasSubstr("\"rate_scale_estimated\": true"));
  fs::remove_all(robot.dir);
}

// wheels.csv with its omega column zeroed: a reference that is not the
// robot's twist (issue #20: one yaw moved 45 -> 64 deg, residual RMS 156
// mm/s against 0.36, negative information eigenvalues, and written).
void zero_omega(const fs::path& wheels) {
  std::ifstream in(wheels);
  std::string text, line;
  while (std::getline(in, line)) {
    const auto comma = line.rfind(',');
    const bool data = !line.empty() && line[0] != '#' && line[0] != 't';
    text += (data ? line.substr(0, comma) + ",0" : line) + "\n";
  }
  in.close();
  std::ofstream(wheels) << text;
}

TEST(CalibrateCli, ExactRefusesAModelThatDoesNotExplainTheDataUnlessForced) {
  const CheckRobot robot("cal-misfit");
  const fs::path& dir = robot.dir;
  // The same log as it is passes the check, by far.
  const auto good = test::run_moa(calibrate_args(dir, "exact"));
  ASSERT_EQ(good.exit_code, 0) << good.err;
  EXPECT_THAT(good.out, HasSubstr("model check: residual "));
  EXPECT_THAT(good.out, HasSubstr("accepted up to 4;"));
  fs::remove(dir / "cal.yaml");

  zero_omega(dir / "wheels.csv");
  const auto r = test::run_moa(calibrate_args(dir, "exact"));
  EXPECT_EQ(r.exit_code, 1);
  expect_one_line_error(
      r,
      "--method exact: refused, the calibrated model does not explain the data: at the "
      "calibrated mounts the counts disagree with a rigid motion by ");
  EXPECT_THAT(r.err, HasSubstr("Nothing written (--force writes it anyway)"));
  EXPECT_FALSE(fs::exists(dir / "cal.yaml"));

  const auto forced = test::run_moa(calibrate_args(dir, "exact") + " --force");
  ASSERT_EQ(forced.exit_code, 0) << forced.err;
  EXPECT_THAT(forced.err, HasSubstr("warning: the calibrated model does not explain the data"));
  EXPECT_THAT(forced.out, HasSubstr("kept as forced: "));
  EXPECT_TRUE(fs::exists(dir / "cal.yaml"));
  fs::remove_all(dir);
}

TEST(CalibrateCli, AMountWithANegativeScaleIsRefusedEvenWhenForced) {
  // The faults-spikes scenario, seed 2: spikes in the counts drive one
  // sensor's fitted scale x through zero (to -0.88). Before, the config
  // writer refused it as "config: sensor 'm4': key 'scale': must be > 0".
  const fs::path dir = test::scratch_dir("cal-negative-scale");
  const auto sim = test::run_moa("simulate --scenario faults-spikes --seed 2 --quiet --out " +
                                 (dir / "log").string());
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  const std::string args = "calibrate --config " + (dir / "log" / "robot.yaml").string() +
                           " --log " + (dir / "log").string() + " --method exact --out " +
                           (dir / "cal.yaml").string();
  for (const std::string force : {"", " --force"}) {
    const auto r = test::run_moa(args + force);
    EXPECT_EQ(r.exit_code, 1) << force;
    expect_one_line_error(r, "--method exact: refused, sensor 'm4' calibrated to position");
    EXPECT_THAT(r.err, HasSubstr("not a sensor mount (a scale must be positive)"));
    EXPECT_FALSE(fs::exists(dir / "cal.yaml"));
  }
  fs::remove_all(dir);
}

TEST(CalibrateCli, PapersExampleGivesEquation53WithKimleeAndEquation52WithExact) {
  // Kim & Lee Section V as a log: 3 s of rows of 12 packets at 6400 fps,
  // the exact reference per row. kimlee sums the rows into the paper's
  // M = 10 measurements.
  SensorArray nominal = test::kimlee_nominal();
  SensorArray truth = nominal;
  for (int i = 0; i < 3; ++i) truth[i].position *= 1.05;
  const std::vector<std::string> names{"m1", "m2", "m3"};
  const auto rotate = [](double) { return Twist2{{0.0, 0.0}, 1.0 / 3.0}; };
  const fs::path dir =
      write_reference_log("cal-kimlee", nominal, truth, rotate, 3.0, 12.0 / 6400.0, {}, names);
  const std::array<double, 6> eq53{0.912, -0.526, 0.000, 1.053, -0.912, -0.526};

  const auto k = test::run_moa(calibrate_args(dir, "kimlee"));
  ASSERT_EQ(k.exit_code, 0) << k.err;
  EXPECT_THAT(k.out, HasSubstr("rank 3 of 6"));
  EXPECT_THAT(k.out, HasSubstr("summed into 10 measurements"));
  EXPECT_THAT(k.out, HasSubstr("S is rank deficient"));
  const io::RobotConfig kl = io::read_config(dir / "cal.yaml");
  for (int i = 0; i < 3; ++i) {
    for (int a = 0; a < 2; ++a) {
      EXPECT_NEAR(kl.array[i].position(a) / 0.3, eq53[static_cast<std::size_t>(2 * i + a)], 0.002);
    }
    EXPECT_EQ(kl.array[i].yaw, nominal[i].yaw);
  }

  const auto e = test::run_moa(calibrate_args(dir, "exact"));
  ASSERT_EQ(e.exit_code, 0) << e.err;
  EXPECT_THAT(e.out, HasSubstr("yaw, scale x, scale y not excited by the motion: kept at nominal"));
  const io::RobotConfig ex = io::read_config(dir / "cal.yaml");
  for (int i = 0; i < 3; ++i) {
    EXPECT_LT((ex.array[i].position - truth[i].position).norm(), 0.5e-3)
        << names[static_cast<std::size_t>(i)];
  }
  fs::remove_all(dir);
}

TEST(CalibrateCli, GuidedCalibratesFromThreeRecordings) {
  std::mt19937_64 rng(32);
  const SensorArray nominal = test::four_sensor_nominal();
  const SensorArray truth = test::perturbed(nominal, rng, 0.008, 0.07, 0.04, 3);
  const fs::path dir = test::scratch_dir("cal-guided");
  const auto record = [&](const std::string& name, const test::TwistScript& script, double T) {
    test::write_log(test::synthesise(truth, script, T, 0.01, true, 1e-3), truth, kNames,
                    dir / name);
  };
  record(
      "push-x",
      [](double) {
        return Twist2{{0.25, 0.0}, 0.0};
      },
      4.0);
  record(
      "push-y",
      [](double) {
        return Twist2{{0.0, 0.25}, 0.0};
      },
      4.0);
  record(
      "spin",
      [](double) {
        return Twist2{{0.0, 0.0}, std::numbers::pi};
      },
      10.0);
  io::RobotConfig config{kNames, nominal};
  io::write_config(config, dir / "nominal.yaml");
  const auto r = test::run_moa(
      "calibrate --config " + (dir / "nominal.yaml").string() + " --method guided --push-x " +
      (dir / "push-x").string() + " --push-y " + (dir / "push-y").string() + " --spin " +
      (dir / "spin").string() + " --distance 1 --turns 5 --out " + (dir / "cal.yaml").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("5 turns counter-clockwise"));
  const io::RobotConfig cal = io::read_config(dir / "cal.yaml");
  for (int i = 0; i < 4; ++i) {
    const SensorMount& m = cal.array[i];
    EXPECT_LT((m.position - truth[i].position).cwiseAbs().maxCoeff(), 0.5e-3) << kNames[i];
    EXPECT_LT(std::abs(wrap_angle(m.yaw - truth[i].yaw)), 0.2 * std::numbers::pi / 180.0);
    EXPECT_LT((m.scale - truth[i].scale).cwiseAbs().maxCoeff(), 0.003);
    EXPECT_EQ(m.mirrored, truth[i].mirrored) << kNames[i];
  }
  fs::remove_all(dir);
}

TEST(CalibrateCli, JsonReportHasTheSameFields) {
  std::mt19937_64 rng(33);
  const SensorArray nominal = test::four_sensor_nominal();
  const SensorArray truth = test::perturbed(nominal, rng, 0.005, 0.05, 0.03);
  const fs::path dir =
      write_reference_log("cal-json", nominal, truth, test::mixed_motion, 4.0, 0.01, {});
  const auto r = test::run_moa(calibrate_args(dir, "exact") + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  EXPECT_THAT(r.out, HasSubstr("\"method\": \"exact\""));
  EXPECT_THAT(r.out, HasSubstr("\"name\": \"d\""));
  EXPECT_THAT(r.out, HasSubstr("\"residual_rms_m_s\""));
  EXPECT_THAT(r.out, HasSubstr("\"reference_noise_sd\""));
  fs::remove_all(dir);
}

class CalibrateCliBadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    const SensorArray nominal = test::four_sensor_nominal();
    dir_ = write_reference_log("cal-bad", nominal, nominal, test::mixed_motion, 1.0, 0.01, {});
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string config() const { return (dir_ / "nominal.yaml").string(); }
  std::string out() const { return (dir_ / "cal.yaml").string(); }
  fs::path dir_;
};

TEST_F(CalibrateCliBadInput, MissingWheelsCsvIsAnError) {
  fs::remove(dir_ / "wheels.csv");
  const auto r = test::run_moa(calibrate_args(dir_, "exact"));
  expect_one_line_error(r, "wheels.csv: not found: --method exact needs the reference twists");
  EXPECT_FALSE(fs::exists(out()));
}

TEST_F(CalibrateCliBadInput, TooFewReferenceIntervalsIsAnError) {
  {
    std::ofstream w(dir_ / "wheels.csv");
    w << "t,vx,vy,omega\n0.0,0,0,0\n0.05,0.1,0,0.2\n0.1,0.1,0,0.2\n";
  }
  const auto r = test::run_moa(calibrate_args(dir_, "exact"));
  expect_one_line_error(
      r,
      "wheels.csv: 2 usable reference interval(s) within the time span of mice.csv; --method "
      "exact needs at least 3");
  EXPECT_FALSE(fs::exists(out()));
}

TEST_F(CalibrateCliBadInput, MalformedWheelsRowNamesFileAndLine) {
  {
    std::ofstream w(dir_ / "wheels.csv", std::ios::app);
    w << "2.0,0.1,abc,0\n";
  }
  const auto r = test::run_moa(calibrate_args(dir_, "exact"));
  expect_one_line_error(r, "wheels.csv:");
  EXPECT_THAT(r.err, HasSubstr("abc"));
  EXPECT_FALSE(fs::exists(out()));
}

TEST_F(CalibrateCliBadInput, CameraReferenceWithoutCameraCsvIsAnError) {
  const auto r = test::run_moa(calibrate_args(dir_, "exact") + " --reference camera");
  expect_one_line_error(
      r,
      "camera.csv: not found: --method exact --reference camera needs the camera's "
      "fixes");
  EXPECT_FALSE(fs::exists(out()));
}

TEST_F(CalibrateCliBadInput, CameraPositionsWithTooFewFixesAreAnError) {
  std::ofstream(dir_ / "camera.csv") << "t,x,y\n0,0,0\n0.1,0.01,0\n";
  const auto r = test::run_moa(calibrate_args(dir_, "exact") + " --reference camera");
  expect_one_line_error(r, "fewer than 20 windows between fixes");
  EXPECT_FALSE(fs::exists(out()));
}

TEST_F(CalibrateCliBadInput, CameraWithTooFewFixesIsAnError) {
  std::ofstream(dir_ / "camera.csv") << "t,x,y,theta\n0,0,0,0\n0.1,0.01,0,0.01\n";
  const auto r = test::run_moa(calibrate_args(dir_, "exact") + " --reference camera");
  expect_one_line_error(r, "fewer than 20 windows between fixes");
  EXPECT_FALSE(fs::exists(out()));
}

TEST_F(CalibrateCliBadInput, CameraWithNanNamesFileAndLine) {
  std::ofstream(dir_ / "camera.csv") << "t,x,y,theta\n0,0,0,0\n0.1,nan,0,0.01\n";
  const auto r = test::run_moa(calibrate_args(dir_, "exact") + " --reference camera");
  expect_one_line_error(r, "camera.csv:3");
  EXPECT_FALSE(fs::exists(out()));
}

TEST_F(CalibrateCliBadInput, ReferenceIsForExactOnly) {
  expect_one_line_error(test::run_moa(calibrate_args(dir_, "kimlee") + " --reference camera"),
                        "--reference is used by --method exact only");
}

TEST_F(CalibrateCliBadInput, GuidedFlagsWithAReferenceMethodAreErrors) {
  expect_one_line_error(test::run_moa(calibrate_args(dir_, "exact") + " --push-x " + dir_.string()),
                        "--push-x is not used by --method exact: it belongs to --method guided");
  expect_one_line_error(test::run_moa(calibrate_args(dir_, "kimlee") + " --turns 5"),
                        "--turns is not used by --method kimlee: it belongs to --method guided");
}

TEST_F(CalibrateCliBadInput, ReferenceMethodWithoutLogIsAnError) {
  expect_one_line_error(
      test::run_moa("calibrate --config " + config() + " --method exact --out " + out()),
      "--method exact needs --log DIR");
}

TEST_F(CalibrateCliBadInput, GuidedNeedsItsRecordingsAndNotALog) {
  const std::string base = "calibrate --config " + config() + " --method guided --out " + out();
  const std::string d = dir_.string();
  expect_one_line_error(test::run_moa(base + " --log " + d + " --push-x " + d),
                        "--log is not used by --method guided");
  expect_one_line_error(test::run_moa(base + " --push-x " + d + " --distance 1 --turns 5"),
                        "--method guided needs --spin DIR");
  expect_one_line_error(test::run_moa(base + " --push-x " + d + " --spin " + d + " --turns 5"),
                        "--method guided needs --distance METRES");
  expect_one_line_error(
      test::run_moa(base + " --push-x " + d + " --spin " + d + " --distance 0 --turns 5"),
      "--distance 0: must be a positive number of metres");
  expect_one_line_error(
      test::run_moa(base + " --push-x " + d + " --spin " + d + " --distance 1 --turns 0"),
      "--turns 0: must be a non-zero number of turns");
  EXPECT_FALSE(fs::exists(out()));
}

TEST_F(CalibrateCliBadInput, SensorThatCountedNothingInAPushIsNamed) {
  // Rewrite mice.csv without sensor c's rows: it counted nothing.
  std::ifstream in(dir_ / "mice.csv");
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) {
    if (line.find(",c,") == std::string::npos) lines.push_back(line);
  }
  in.close();
  {
    std::ofstream o(dir_ / "mice.csv");
    for (const auto& l : lines) o << l << "\n";
  }
  const auto r = test::run_moa("calibrate --config " + config() + " --method guided --push-x " +
                               dir_.string() + " --spin " + dir_.string() +
                               " --distance 1 --turns 5 --out " + out());
  expect_one_line_error(r, "sensor 'c' counted nothing during the push along x");
  EXPECT_FALSE(fs::exists(out()));
}

TEST_F(CalibrateCliBadInput, ImpossibleCountsAreRefusedWithTheLine) {
  // Line 40 of mice.csv gets dx = 2e9 (31 km in a row): refused by every
  // method as moa odometry refuses it, naming the line.
  std::ifstream in(dir_ / "mice.csv");
  std::string text, line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (n == 40) {
      const auto first = line.find(',', line.find(',') + 1);  // after t,sensor
      const auto second = line.find(',', first + 1);
      line = line.substr(0, first + 1) + "2000000000" + line.substr(second);
    }
    text += line + "\n";
  }
  in.close();
  std::ofstream(dir_ / "mice.csv") << text;
  const std::string guided = "calibrate --config " + config() + " --method guided --push-x " +
                             dir_.string() + " --spin " + dir_.string() +
                             " --distance 1 --turns 1 --out " + out();
  for (const std::string& args :
       {calibrate_args(dir_, "exact"), calibrate_args(dir_, "kimlee"), guided}) {
    const auto r = test::run_moa(args);
    EXPECT_EQ(r.exit_code, 1) << args;
    expect_one_line_error(r, (dir_ / "mice.csv").string() + ":40: row at t = ");
    EXPECT_THAT(r.err, HasSubstr("counts imply a speed far beyond what the sensor can track"));
    EXPECT_FALSE(fs::exists(out()));
  }
}

TEST_F(CalibrateCliBadInput, UnknownMethodIsRejected) {
  const auto r = test::run_moa(calibrate_args(dir_, "magic"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, HasSubstr("--method"));
  EXPECT_FALSE(fs::exists(out()));
}

TEST(ExperimentCli, ListsTheCalibrationExperiments) {
  const auto r = test::run_moa("experiment --list");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("kimlee-example"));
  EXPECT_THAT(r.out, HasSubstr("calibration-crb"));
}

TEST(ExperimentCli, KimleeExamplePrintsEquationsAndOurResults) {
  const auto r = test::run_moa("experiment kimlee-example --runs 3");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("Kim & Lee's result, eq. (53)"));
  EXPECT_THAT(r.out, HasSubstr("0.9116  -0.5263   0.0000   1.0526"));  // minimum norm, noise-free
  EXPECT_THAT(r.out, HasSubstr("0.9093  -0.5250   0.0000   1.0500"));  // exact = eq. (52)
  EXPECT_THAT(r.out, HasSubstr("Fig. 3"));
  const auto j = test::run_moa("experiment kimlee-example --runs 3 --json");
  ASSERT_EQ(j.exit_code, 0) << j.err;
  EXPECT_EQ(std::count(j.out.begin(), j.out.end(), '\n'), 1);
  EXPECT_THAT(j.out, HasSubstr("\"paper_eq53\""));
  EXPECT_THAT(j.out, HasSubstr("\"kimlee_rank\": 3"));
}

// The self-calibration experiment's report page: the representative run
// with --self-calibrate, and its scale plot.
TEST(ExperimentCli, SelfCalibrationReportPlotsTheScaleOverTime) {
  const fs::path page = test::scratch_dir("experiment-report") / "page.html";
  const auto r =
      test::run_moa("experiment self-calibration --runs 1 --seed 101 --report " + page.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("report written to " + page.string()));
  const std::string html = test::read_text(page);
  EXPECT_THAT(html, HasSubstr("<canvas id=\"chart-self-calibration\">"));
  EXPECT_THAT(html, HasSubstr("--self-calibration self-calibration.csv"));
  EXPECT_THAT(html, HasSubstr("with online self-calibration"));
}

TEST(ExperimentCli, UnknownExperimentIsAnError) {
  expect_one_line_error(test::run_moa("experiment no-such-thing"),
                        "unknown experiment 'no-such-thing' (available: ");
}

}  // namespace
}  // namespace moa
