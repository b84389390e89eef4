// moa config init: a commented robot.yaml for a common layout that moa
// odometry accepts, numbers checked, nothing overwritten without --force.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>

#include "moa/analysis/evaluate.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/config_init.hpp"
#include "moa/formats/log.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

std::string contents(const fs::path& file) {
  std::ifstream in(file);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(ConfigInit, PolygonIsAcceptedByOdometryWhichTracksALogOfThatRobot) {
  const auto dir = test::scratch_dir("config_init");
  const fs::path config = dir / "init.yaml";
  const auto r = test::run_moa(
      "config init --layout polygon --sensors 4 --radius 0.1 --cpi 1600 "
      "--preset ADNS-3080 --out " +
      config.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(contents(config), HasSubstr("# Frames: the robot frame has x forward"));

  // The sensors where the polygon puts them, computed here: r (cos a, sin a).
  const io::RobotConfig read = io::read_config(config);
  ASSERT_EQ(read.array.size(), 4);
  for (int i = 0; i < 4; ++i) {
    const double a = i * std::numbers::pi / 2.0;
    EXPECT_EQ(read.names[static_cast<std::size_t>(i)], "m" + std::to_string(i + 1));
    EXPECT_NEAR(read.array[i].position.x(), 0.1 * std::cos(a), 1e-9);
    EXPECT_NEAR(read.array[i].position.y(), 0.1 * std::sin(a), 1e-9);
    EXPECT_EQ(read.array[i].yaw, 0.0);
    EXPECT_EQ(read.array[i].cpi, 1600.0);
    ASSERT_TRUE(read.array[i].max_speed.has_value());
    EXPECT_NEAR(*read.array[i].max_speed, 40.0 * 0.0254, 1e-12);  // ADNS-3080: 40 in/s
  }

  // A noise-free log of a robot built to that layout, replayed with the
  // written config: within a millimetre of the truth.
  const SensorArray robot = regular_polygon(4, 0.1, 0.0, read.array[0]);
  const auto log = test::synthesise(robot, test::mixed_motion, 10.0, 0.01);
  test::write_log(log, robot, {"m1", "m2", "m3", "m4"}, dir);
  const auto odo = test::run_moa("odometry --config " + config.string() + " --log " + dir.string() +
                                 " --out " + (dir / "odom.csv").string());
  ASSERT_EQ(odo.exit_code, 0) << odo.err;
  TrajectoryErrorAccumulator acc(log.truth);
  io::TruthReader odometry(dir / "odom.csv");
  while (const auto row = odometry.next()) acc.add(row->t, row->pose);
  EXPECT_EQ(acc.result().samples, 1000u);
  EXPECT_LT(acc.result().max_translation, 1e-3);
}

TEST(ConfigInit, SensorsOneByOneInDegreesWithMirroring) {
  const auto dir = test::scratch_dir("config_init_one");
  const fs::path config = dir / "robot.yaml";
  const auto r = test::run_moa("config init --cpi 1000 --out " + config.string() +
                               " --sensor front=0.12,0,-90,mirrored --sensor back=-0.12,0.01,45");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::RobotConfig read = io::read_config(config);
  ASSERT_EQ(read.array.size(), 2);
  EXPECT_EQ(read.names[0], "front");
  EXPECT_EQ(read.names[1], "back");
  EXPECT_NEAR(read.array[0].yaw, -std::numbers::pi / 2.0, 1e-15);
  EXPECT_TRUE(read.array[0].mirrored);
  EXPECT_NEAR(read.array[1].yaw, std::numbers::pi / 4.0, 1e-15);
  EXPECT_FALSE(read.array[1].mirrored);
  EXPECT_EQ(read.array[1].position, Eigen::Vector2d(-0.12, 0.01));
  EXPECT_EQ(read.array[1].cpi, 1000.0);
  EXPECT_FALSE(read.array[1].max_speed.has_value());
}

// A huge --theta-deg is a turn like any other (issue #47, item 10: 1e308
// wrote four coincident sensors, their angles rounded to one): the polygon
// is the one of the angle reduced to a turn.
TEST(ConfigInit, AHugeThetaGivesThePolygonOfTheAngleReducedToATurn) {
  const auto dir = test::scratch_dir("config_init_huge_theta");
  for (const std::string theta : {"1e308", "-1e300", "1e20"}) {
    SCOPED_TRACE(theta);
    const fs::path config = dir / "robot.yaml";
    const auto r = test::run_moa(
        "config init --layout polygon --sensors 4 --radius 0.1 --cpi 800 "
        "--force --theta-deg " +
        theta + " --out " + config.string());
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const io::RobotConfig read = io::read_config(config);
    ASSERT_EQ(read.array.size(), 4);
    const double first = std::fmod(std::stod(theta), 360.0) * std::numbers::pi / 180.0;
    for (int i = 0; i < 4; ++i) {
      const double angle = first + i * std::numbers::pi / 2.0;
      EXPECT_NEAR(read.array[i].position.x(), 0.1 * std::cos(angle), 1e-9) << i;
      EXPECT_NEAR(read.array[i].position.y(), 0.1 * std::sin(angle), 1e-9) << i;
      for (int j = 0; j < i; ++j) {
        EXPECT_GT((read.array[i].position - read.array[j].position).norm(), 0.1) << i << j;
      }
    }
  }
}

// The config reads as a person would write it: the rated speed as the
// datasheet's decimal, no "-0" where cos and sin of the layout give -0.
TEST(ConfigInit, NumbersAreWrittenAsAPersonWouldWriteThem) {
  const auto dir = test::scratch_dir("config_init_numbers");
  const fs::path config = dir / "robot.yaml";
  const auto r = test::run_moa(
      "config init --layout polygon --sensors 4 --radius 0.1 --preset HDNS-2051 --out " +
      config.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string text = contents(config);
  EXPECT_THAT(text, HasSubstr("    max_speed: 0.3556\n"));                       // 14 in/s
  EXPECT_THAT(text, ::testing::Not(::testing::ContainsRegex("-0([^.0-9]|$)")));  // -0, not -0.1
  EXPECT_NEAR(io::read_config(config).array[0].max_speed.value(), 14 * 0.0254, 1e-15);
}

// The PixArt presets: the config takes the data sheet's default cpi and
// rated speed, and its comments carry the figures a person needs; a cpi the
// part cannot be set to, and a flow chip without --cpi, are refused.
TEST(ConfigInit, PixArtPresetsCarryTheirDataSheetFigures) {
  const auto dir = test::scratch_dir("config_init_pixart");
  const fs::path config = dir / "robot.yaml";
  const std::string polygon =
      "config init --layout polygon --sensors 4 --radius 0.1 --force --out " + config.string();
  auto r = test::run_moa(polygon + " --preset PMW3360");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  io::RobotConfig read = io::read_config(config);
  EXPECT_EQ(read.array[0].cpi, 1600.0);
  EXPECT_NEAR(*read.array[0].max_speed, 250 * 0.0254, 1e-12);  // 250 in/s
  std::string text = contents(config);
  EXPECT_THAT(text, HasSubstr("# PMW3360, from its data sheet:"));
  EXPECT_THAT(text, HasSubstr("resolution 100 to 12000 cpi in steps of 100"));
  EXPECT_THAT(text, HasSubstr("rated acceleration 50 g = 490.3 m/s^2"));  // 50 x 9.80665
  EXPECT_THAT(text, HasSubstr("frame rate up to 12000 /s"));
  EXPECT_THAT(text, HasSubstr("resolution error 1 % typical"));
  EXPECT_THAT(text, HasSubstr("stops tracking when lifted 2 mm"));

  r = test::run_moa(polygon + " --preset PMW3389 --cpi 16000");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  read = io::read_config(config);
  EXPECT_EQ(read.array[0].cpi, 16000.0);
  EXPECT_NEAR(*read.array[0].max_speed, 400 * 0.0254, 1e-12);  // 400 in/s
  EXPECT_THAT(contents(config), HasSubstr("resolution 50 to 16000 cpi in steps of 50"));

  r = test::run_moa(polygon + " --preset PAA5100 --cpi 2500");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  read = io::read_config(config);
  EXPECT_EQ(read.array[0].cpi, 2500.0);
  EXPECT_FALSE(read.array[0].max_speed.has_value());  // not rated as a speed
  text = contents(config);
  EXPECT_THAT(text, HasSubstr("working height 15 mm to 35 mm"));
  EXPECT_THAT(text, HasSubstr("resolution: none to set"));

  r = test::run_moa(polygon + " --preset PMW3901 --cpi 1000");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  text = contents(config);
  EXPECT_THAT(text, HasSubstr("working height 80 mm and up"));
  EXPECT_THAT(text, HasSubstr("rated flow 7.4 rad/s"));

  const struct {
    std::string args;
    std::string message;
  } bad[] = {
      {polygon + " --preset PMW3360 --cpi 150",
       "--cpi 150: the PMW3360 is set from 100 to 12000 cpi in steps of 100"},
      {polygon + " --preset PMW3360 --cpi 12100", "--cpi 12100: the PMW3360"},
      {polygon + " --preset PMW3389 --cpi 16025", "--cpi 16025: the PMW3389"},
      {polygon + " --preset ADNS-3080 --cpi 800", "--cpi 800: the ADNS-3080 is set from 400"},
      {polygon + " --preset PAA5100", "--preset PAA5100: a flow chip has no resolution to set"},
  };
  for (const auto& c : bad) {
    fs::remove(config);
    r = test::run_moa(c.args);
    EXPECT_NE(r.exit_code, 0) << c.args;
    EXPECT_THAT(r.err, HasSubstr(c.message)) << c.args;
    EXPECT_FALSE(fs::exists(config)) << c.args;
  }
}

TEST(ConfigInit, RefusesToOverwriteWithoutForce) {
  const auto dir = test::scratch_dir("config_init_force");
  const fs::path config = dir / "robot.yaml";
  { std::ofstream(config) << "mine\n"; }
  const std::string args =
      "config init --layout polygon --sensors 3 --radius 0.1 --cpi 800 --out " + config.string();
  const auto r = test::run_moa(args);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, HasSubstr("--force"));
  EXPECT_EQ(contents(config), "mine\n");
  ASSERT_EQ(test::run_moa(args + " --force").exit_code, 0);
  EXPECT_EQ(io::read_config(config).array.size(), 3);
}

TEST(ConfigInit, BadNumbersAreRefusedNamingTheOptionAndWriteNothing) {
  const auto dir = test::scratch_dir("config_init_bad");
  const fs::path config = dir / "robot.yaml";
  const std::string polygon = "config init --layout polygon --out " + config.string();
  const struct {
    std::string args;
    std::string message;
  } cases[] = {
      {polygon + " --sensors 4 --radius nan --cpi 800", "--radius"},
      {polygon + " --sensors 4 --radius -0.1 --cpi 800", "--radius -0.1"},
      {polygon + " --sensors 4 --radius 0 --cpi 800", "--radius 0"},
      {polygon + " --sensors 1 --radius 0.1 --cpi 800", "--sensors 1"},
      {polygon + " --sensors 17 --radius 0.1 --cpi 800", "--sensors 17"},
      {polygon + " --sensors 4 --radius 0.1 --cpi inf", "--cpi"},
      {polygon + " --sensors 4 --radius 0.1 --cpi -800", "--cpi -800"},
      {polygon + " --sensors 4 --radius 0.1", "--cpi"},
      {polygon + " --sensors 4 --radius 0.1 --theta-deg nan --cpi 800", "--theta-deg"},
      {polygon + " --sensors 4 --radius 0.1 --preset ADNS-9999", "--preset ADNS-9999"},
      {"config init --cpi 800 --out " + config.string() + " --sensor a=0.1,nan,0 --sensor b=0,0,0",
       "--sensor a=0.1,nan,0"},
      {"config init --cpi 800 --out " + config.string() + " --sensor a=0.1,0,0", "at least 2"},
  };
  for (const auto& c : cases) {
    const auto r = test::run_moa(c.args);
    EXPECT_NE(r.exit_code, 0) << c.args;
    EXPECT_THAT(r.err, HasSubstr(c.message)) << c.args;
    EXPECT_FALSE(fs::exists(config)) << c.args;
  }
}

}  // namespace
}  // namespace moa
