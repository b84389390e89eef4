// The report page in a real browser: Debian's headless Chromium loads it
// from a file, runs its script, and every chart is drawn without an error.
// Skipped (and says so) when no Chromium is on the PATH; `make deps`
// installs it, so CI always runs it.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include "moa/formats/config.hpp"
#include "moa/web/report.hpp"
#include "support/browser.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

TEST(ReportBrowser, ChromiumDrawsEveryChartWithoutErrors) {
  const auto chromium = test::find_chromium();
  if (!chromium) GTEST_SKIP() << "no chromium on the PATH (make deps installs it)";

  const fs::path dir = test::scratch_dir("report-browser");
  const SensorArray array = test::skewed_array();
  const auto log = test::synthesise(array, test::mixed_motion, 10.0, 0.01, true, 1e-3);
  test::write_log(log, array, {"a", "b", "c", "d"}, dir);
  io::RobotConfig config = io::read_config(dir / "robot.yaml");
  for (int i = 0; i < config.array.size(); ++i) config.array[i].max_speed = 0.35;
  io::write_config(config, dir / "robot.yaml");
  config.array[0].position += Eigen::Vector2d(0.004, 0.0);
  io::write_config(config, dir / "cal.yaml");
  {
    std::ofstream camera(dir / "camera.csv");
    camera << "t,x,y\n";
    for (std::size_t k = 0; k < log.truth.size(); k += 20) {
      camera << log.truth[k].t << ',' << log.truth[k].pose.t.x() << ',' << log.truth[k].pose.t.y()
             << '\n';
    }
  }
  const auto odometry =
      test::run_moa("odometry --config " + (dir / "robot.yaml").string() + " --log " +
                    dir.string() + " --out " + (dir / "odom.csv").string());
  ASSERT_EQ(odometry.exit_code, 0) << odometry.err;
  // The self-calibration's estimates of the same log (its own odometry, not plotted).
  const auto calibrated =
      test::run_moa("odometry --quiet --config " + (dir / "robot.yaml").string() + " --log " +
                    dir.string() + " --out " + (dir / "odom-cal.csv").string() +
                    " --self-calibration " + (dir / "self-calibration.csv").string());
  ASSERT_EQ(calibrated.exit_code, 0) << calibrated.err;
  const fs::path page = dir / "report.html";
  const auto report = test::run_moa(
      "report --config " + (dir / "robot.yaml").string() + " --log " + dir.string() +
      " --odometry " + (dir / "odom.csv").string() + " --truth " + (dir / "truth.csv").string() +
      " --calibration " + (dir / "cal.yaml").string() + " --self-calibration " +
      (dir / "self-calibration.csv").string() + " --out " + page.string());
  ASSERT_EQ(report.exit_code, 0) << report.err;

  const test::BrowserPage loaded = test::load_page(
      *chromium, "file://" + fs::absolute(page).string(), dir, 1280, 4000, 10000, 120);
  ASSERT_EQ(loaded.failure(), "");
  const std::string& dom = loaded.dom;
  const std::string& console = loaded.console;

  // The script ran to its end, nothing went wrong, and the console stayed quiet.
  EXPECT_THAT(dom, HasSubstr("data-moa-status=\"ready\""));
  const std::string errors = test::tag_of(dom, "moa-errors");
  EXPECT_THAT(errors, HasSubstr("hidden")) << dom.substr(dom.find("id=\"moa-errors\""), 600);
  EXPECT_EQ(console.find("CONSOLE"), std::string::npos) << console;
  // Every chart has pixels and its data elements on its canvas: at least one
  // bar per timeline row (4 sensors and the twist source, all used throughout
  // this noise-free run), hundreds of points on the others; the scales of 4
  // sensors, 2 axes, about once a second over 10 s.
  const std::pair<const char*, unsigned long> charts[] = {
      {"chart-trajectory", 100}, {"chart-errors", 100},          {"chart-timeline", 5},
      {"chart-speed", 100},      {"chart-self-calibration", 80}, {"chart-layout", 8}};
  for (const auto& [id, least] : charts) {
    const std::string tag = test::tag_of(dom, id);
    EXPECT_THAT(tag, HasSubstr("data-painted=\"1\"")) << id << ": " << tag;
    std::smatch points;
    ASSERT_TRUE(std::regex_search(tag, points, std::regex("data-points=\"([0-9]+)\""))) << tag;
    EXPECT_GE(std::stoul(points[1]), least) << id;
  }
  if (!HasFailure()) fs::remove_all(dir);
}

}  // namespace
}  // namespace moa
