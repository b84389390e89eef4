// moa calibrate --speed-knots end to end on the simulator's speed-scale
// scenario: the tables it writes against the scenario's true tables, the
// knots it refuses, and the flags it refuses.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "moa/formats/config.hpp"
#include "support/json_value.hpp"
#include "support/run.hpp"
#include "support/slow.hpp"
#include "support/synth.hpp"

namespace moa {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

// One simulated run of speed-scale, shared by the tests of this file.
class SpeedScaleCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(test::scratch_dir("speed-scale-cli"));
    const auto r =
        test::run_moa("simulate --scenario speed-scale --seed 11 --out " + dir_->string());
    ASSERT_EQ(r.exit_code, 0) << r.err;
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
  }
  static std::string calibrate(const std::string& extra) {
    return "calibrate --method exact --config " + (*dir_ / "robot.yaml").string() + " --log " +
           dir_->string() + " --out " + (*dir_ / "cal.yaml").string() + " " + extra;
  }
  static fs::path* dir_;
};
fs::path* SpeedScaleCli::dir_ = nullptr;

// The knots are the union of the true tables' (0.25, 1, 2 / 0.5, 1.5, 2 /
// 0.5, 2): every true table is piecewise linear on them, so the fit has no
// model error and each knot's error is its noise, within 4 sigma.
TEST_F(SpeedScaleCli, CalibratedTablesMatchTheTrueOnesWithinTheirSigma) {
  MOA_SKIP_UNDER_SANITIZER("a 60 s calibration with a speed table");
  const auto r = test::run_moa(calibrate("--speed-knots 0.25,0.5,1,1.5,2 --json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::RobotConfig truth = io::read_config(*dir_ / "robot.true.yaml");
  const io::RobotConfig cal = io::read_config(*dir_ / "cal.yaml");
  const test::JsonValue report = test::JsonValue::parse(r.out);
  const std::array<double, 5> knots{0.25, 0.5, 1.0, 1.5, 2.0};
  for (int i = 0; i < 4; ++i) {
    SCOPED_TRACE(cal.names[static_cast<std::size_t>(i)]);
    const SpeedScale& fitted = cal.array[i].speed_scale;
    ASSERT_TRUE(fitted.active());
    ASSERT_EQ(fitted.size(), 5);
    const auto& sigma = report["sensors"][static_cast<std::size_t>(i)]["speed_scale"]["sigma"];
    // The true table relative to its value at the first knot (the gauge).
    const SpeedScale& t = truth.array[i].speed_scale;
    for (int k = 1; k < 5; ++k) {
      const double expected = t.ratio(knots[static_cast<std::size_t>(k)]) / t.ratio(knots[0]);
      const double sd = sigma[static_cast<std::size_t>(k)].number();
      EXPECT_GT(sd, 0.0);
      EXPECT_LT(sd, 0.005);
      EXPECT_LT(std::abs(fitted.ratio_at(k) - expected), 4.0 * sd) << "knot " << k;
    }
    // The scale carries the resolution at the first knot: the truth's there,
    // within 3 sigma of the gauge's (about the other knots' sigma, < 0.001).
    EXPECT_NEAR(cal.array[i].scale.x(), t.ratio(knots[0]), 0.003);
    EXPECT_NEAR(cal.array[i].scale.y(), t.ratio(knots[0]), 0.003);
  }
}

TEST_F(SpeedScaleCli, TheReportPrintsEachKnotWithItsSigma) {
  MOA_SKIP_UNDER_SANITIZER("a 60 s calibration with a speed table");
  const auto r = test::run_moa(calibrate("--speed-knots 0.5,2"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("speed scale: knots 0.5, 2 m/s"));
  EXPECT_THAT(r.out, HasSubstr("knot m/s              ratio      1-sigma      windows"));
  EXPECT_THAT(r.out, HasSubstr("(gauge)"));
}

TEST_F(SpeedScaleCli, KnotsTheDataDoNotReachAreRefused) {
  fs::remove(*dir_ / "cal.yaml");
  const auto r = test::run_moa(calibrate("--speed-knots 0.5,2,4"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("--speed-knots: sensor 'm1': knot 4 m/s not covered by the data: "));
  EXPECT_THAT(r.err, HasSubstr("Nothing written"));
  EXPECT_FALSE(fs::exists(*dir_ / "cal.yaml"));
}

TEST_F(SpeedScaleCli, BadKnotsAndMethodsAreRefused) {
  EXPECT_THAT(test::run_moa(calibrate("--speed-knots 1")).err,
              HasSubstr("--speed-knots: 1 knots, needs 2 to 8"));
  EXPECT_THAT(test::run_moa(calibrate("--speed-knots 1,0.5")).err,
              HasSubstr("--speed-knots: knots must be strictly increasing (0.5 after 1 m/s)"));
  EXPECT_THAT(test::run_moa(calibrate("--speed-knots 0,1,2,3,4,5,6,7,8")).err,
              HasSubstr("--speed-knots: 9 knots, needs 2 to 8"));
  EXPECT_THAT(test::run_moa(calibrate("--speed-knots -1,1")).err,
              HasSubstr("speed_knots: must be >= 0 and finite"));
  EXPECT_THAT(test::run_moa(calibrate("--speed-knots 0.5,2 --reference camera")).err,
              HasSubstr("--speed-knots needs the reference twists of wheels.csv"));
  const auto kimlee = test::run_moa(
      "calibrate --method kimlee --config " + (*dir_ / "robot.yaml").string() + " --log " +
      dir_->string() + " --out " + (*dir_ / "k.yaml").string() + " --speed-knots 0.5,2");
  EXPECT_EQ(kimlee.exit_code, 1);
  EXPECT_THAT(kimlee.err, HasSubstr("--speed-knots is used by --method exact only"));
}

}  // namespace
}  // namespace moa
