// moa evaluate end to end: errors in mm with the distance travelled, a
// verdict against the quantisation floor or a given figure, SI units in JSON.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <regex>
#include <string>

#include "moa/formats/log.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

const fs::path kLog = fs::path(MOA_SOURCE_DIR) / "examples/logs/mixed-motion";

/// The example log's odometry (least squares), written into `dir`.
fs::path odometry_of_example(const fs::path& dir) {
  const fs::path out = dir / "odometry.csv";
  const auto r = test::run_moa("odometry --config " + (kLog / "robot.yaml").string() + " --log " +
                               kLog.string() + " --estimator ls --out " + out.string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return out;
}

double json_number(const std::string& json, const std::string& key) {
  std::smatch m;
  const std::regex re("\"" + key + "\": ([-+0-9.eE]+)");
  if (!std::regex_search(json, m, re)) ADD_FAILURE() << key << " not in " << json;
  return m.empty() ? 0.0 : std::stod(m[1]);
}

TEST(EvaluateCli, PrintsMillimetresOverTheDistanceTravelledAndAVerdict) {
  const auto dir = test::scratch_dir("evaluate_cli");
  const fs::path odometry = odometry_of_example(dir);
  const std::string files =
      " --truth " + (kLog / "truth.csv").string() + " --odometry " + odometry.string();

  // The distance, independently: segment lengths of every truth row (the
  // odometry's last row is the truth's last).
  double distance = 0.0;
  const auto truth = io::read_all<io::TruthRow>(kLog / "truth.csv");
  for (std::size_t k = 1; k < truth.size(); ++k)
    distance += (truth[k].pose.t - truth[k - 1].pose.t).norm();

  const auto json =
      test::run_moa("evaluate --json --config " + (kLog / "robot.yaml").string() + files);
  ASSERT_EQ(json.exit_code, 0) << json.err;
  EXPECT_NEAR(json_number(json.out, "distance_m"), distance, 1e-6 * distance);
  const double max_m = json_number(json.out, "max_translation_m");
  EXPECT_GT(max_m, 0.0);
  EXPECT_LT(max_m, 1e-3);  // SI: metres, a clean log is far below a millimetre

  const auto text = test::run_moa("evaluate --config " + (kLog / "robot.yaml").string() + files +
                                  " --reference-mm 0.001 --reference-label \"a tight bound\"");
  ASSERT_EQ(text.exit_code, 0) << text.err;
  char max_mm[64];
  std::snprintf(max_mm, sizeof max_mm, "max %.3g mm over", max_m * 1e3);
  EXPECT_THAT(text.out, HasSubstr(max_mm));
  EXPECT_THAT(text.out, HasSubstr("m travelled"));
  // Noise-free counts: the only error is rounding, so the run is at the floor.
  EXPECT_THAT(text.out, HasSubstr("verdict                 at the quantisation floor"));
  EXPECT_THAT(text.out, HasSubstr("verdict                 above a tight bound's 0.001 mm"));
  fs::remove_all(dir);
}

TEST(EvaluateCli, ReferenceMustBeAPositiveFiniteNumber) {
  const auto dir = test::scratch_dir("evaluate_cli_ref");
  const fs::path odometry = odometry_of_example(dir);
  for (const char* bad : {"nan", "inf", "-1", "0"}) {
    const auto r = test::run_moa("evaluate --truth " + (kLog / "truth.csv").string() +
                                 " --odometry " + odometry.string() + " --reference-mm " + bad);
    EXPECT_NE(r.exit_code, 0) << bad;
    EXPECT_THAT(r.err, HasSubstr("--reference-mm")) << bad;
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace moa
