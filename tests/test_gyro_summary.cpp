// The gyro in what a run tells its user: the run summary's gyro line (`moa
// odometry`), the report's gyro section and the dashboard's heading source,
// each against an independent count of the diagnostics.csv of the same run
// (its `imu` rows: one per epoch with a gyro reading, fused = 1 when the
// epoch's heading was the gyro's).
#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "moa/formats/config.hpp"
#include "moa/runs/odometry_run.hpp"
#include "moa/runs/run_summary.hpp"
#include "moa/web/dashboard.hpp"
#include "support/http.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa::io {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

/// The gyro-bump scenario (imu.csv), simulated once and removed at exit.
const fs::path& gyro_log() {
  struct Log {
    fs::path dir = test::scratch_dir("gyro-summary-log");
    Log() {
      const auto r =
          test::run_moa("simulate --scenario gyro-bump --seed 101 --out " + dir.string());
      EXPECT_EQ(r.exit_code, 0) << r.err;
    }
    ~Log() { fs::remove_all(dir); }
  };
  static const Log log;
  return log.dir;
}

/// diagnostics.csv counted by hand (t,source,test_ratio,fused,reason,bias,scale).
struct DiagnosticsCounts {
  std::size_t epochs = 0;  ///< `prior` rows: one per epoch
  std::size_t imu = 0;     ///< `imu` rows
  std::size_t fused = 0;   ///< `imu` rows with fused = 1
  std::size_t over = 0;    ///< `imu` rows with a test ratio above 1
  bool last_fused = false;
  std::string last_bias, last_scale;  ///< the last imu row's, as written
};

DiagnosticsCounts count_diagnostics(const fs::path& file) {
  std::ifstream in(file);
  std::string line;
  std::getline(in, line);  // header
  EXPECT_EQ(line, "t,source,test_ratio,fused,reason,bias,scale");
  DiagnosticsCounts c;
  std::string last_t;
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::istringstream fields(line);
    std::string field;
    while (std::getline(fields, field, ',')) f.push_back(field);
    if (f.size() < 4) continue;
    if (f[1] == "prior") {
      ++c.epochs;
      c.last_fused = false;  // the imu row, if any, comes after the prior row
    }
    if (f[1] == "imu") {
      ++c.imu;
      if (f[3] == "1") ++c.fused;
      if (!f[2].empty() && std::stod(f[2]) > 1.0) ++c.over;
      c.last_fused = f[3] == "1";
      if (f.size() == 7) c.last_bias = f[5], c.last_scale = f[6];
    }
  }
  return c;
}

std::size_t rows_of(const fs::path& csv) {
  std::ifstream in(csv);
  std::string line;
  std::size_t n = 0;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] != '#') ++n;
  }
  return n - 1;  // the header
}

TEST(GyroSummary, MoaOdometryPrintsTheHeadingFromTheGyroAsDiagnosticsCsvCountsIt) {
  const fs::path& log = gyro_log();
  const fs::path dir = test::scratch_dir("gyro-summary-cli");
  const fs::path out = dir / "odometry.csv", diagnostics = dir / "diagnostics.csv";
  const auto r = test::run_moa("odometry --config " + (log / "robot.yaml").string() + " --log " +
                               log.string() + " --out " + out.string() + " --diagnostics " +
                               diagnostics.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const DiagnosticsCounts d = count_diagnostics(diagnostics);
  ASSERT_GT(d.imu, 0u) << "the scenario has imu.csv";
  ASSERT_GT(d.fused, 0u);
  EXPECT_EQ(d.epochs, rows_of(out));
  std::smatch m;
  const std::regex line(
      R"(gyro: bias (-?[0-9.]+) rad/s \(sd ([0-9.e+-]+)\), scale ([0-9.]+) \(sd ([0-9.e+-]+)\), latency (-?[0-9.]+) ms \(sd ([0-9.e+-]+)\), heading from the gyro in ([0-9]+) of ([0-9]+) epochs \(([0-9.]+) %\)\n)");
  ASSERT_TRUE(std::regex_search(r.out, m, line)) << r.out;
  EXPECT_EQ(std::stoul(m[7]), d.fused);
  EXPECT_EQ(std::stoul(m[8]), d.epochs);
  // The latency learnt: the scenario's rows are stamped as robot.yaml says
  // (gyro-bump.yaml: 5 ms), so within 4 sd of it, the sd at most the
  // prior's 5 ms, and no line saying the config is off.
  const double latency_ms = std::stod(m[5]), latency_sd_ms = std::stod(m[6]);
  EXPECT_GT(latency_sd_ms, 0.0);
  EXPECT_LE(latency_sd_ms, 5.0);
  EXPECT_NEAR(latency_ms, 5.0, 4 * latency_sd_ms + 0.05);
  EXPECT_EQ(r.out.find("the config says"), std::string::npos) << r.out;
  // The calibration learnt: the simulated gyro's (examples/scenarios/
  // gyro-bump.yaml: bias 0.01 rad/s walking by 3e-5 rad/s/sqrt(s), scale
  // 1.02; robot.yaml says 0 and 1) within a few sd, each sd positive and
  // below the configured initial one (bias_sigma 0.05 rad/s, scale_sigma 0.03).
  const double bias = std::stod(m[1]), bias_sd = std::stod(m[2]);
  const double scale = std::stod(m[3]), scale_sd = std::stod(m[4]);
  EXPECT_GT(bias_sd, 0.0);
  EXPECT_LT(bias_sd, 0.05);
  EXPECT_GT(scale_sd, 0.0);
  EXPECT_LT(scale_sd, 0.03);
  EXPECT_NEAR(bias, 0.01, 4 * bias_sd + 1e-3);
  EXPECT_NEAR(scale, 1.02, 4 * scale_sd + 5e-3);
  // diagnostics.csv's last imu row carries the same calibration (the line
  // above rounds it to 5 and 4 decimals).
  ASSERT_FALSE(d.last_bias.empty());
  EXPECT_NEAR(std::stod(d.last_bias), bias, 5e-6);
  EXPECT_NEAR(std::stod(d.last_scale), scale, 5e-5);

  // --no-imu: no gyro, no gyro line.
  const auto no_imu =
      test::run_moa("odometry --config " + (log / "robot.yaml").string() + " --log " +
                    log.string() + " --out " + (dir / "no-imu.csv").string() + " --no-imu");
  ASSERT_EQ(no_imu.exit_code, 0) << no_imu.err;
  EXPECT_THAT(no_imu.out, Not(HasSubstr("gyro:")));
  fs::remove_all(dir);
}

TEST(GyroSummary, TheSummaryHoldsTheGyroModelAfterTheLastEpoch) {
  const fs::path& log = gyro_log();
  const std::string config_path = (log / "robot.yaml").string();
  const RobotConfig config = read_config(config_path);
  const OdometryOptions options =
      resolve_odometry_options({}, "consensus", {}, false, config, config_path);
  RunSummary::GyroCalibration last;
  std::size_t fused = 0, readings = 0, steps = 0;
  bool last_had_gyro = false;
  const OdometryRun run =
      run_odometry(config, config_path, resolve_log(log), options, [&](const OdometryStep& s) {
        ++steps;
        if (s.estimate.tests.gyro_fused) ++fused;
        if (!std::isnan(s.estimate.tests.gyro) || s.estimate.tests.gyro_fused ||
            s.estimate.tests.gyro_saturated) {
          ++readings;
        }
        // Null before the first gyro row.
        last_had_gyro = s.gyro != nullptr;
        if (s.gyro != nullptr) {
          last = {s.gyro->bias(), std::sqrt(s.gyro->covariance()(0, 0)), s.gyro->scale(), 0.0};
        }
      });
  const RunSummary& s = run.summary;
  ASSERT_TRUE(last_had_gyro);
  EXPECT_EQ(s.epochs, steps);
  EXPECT_EQ(s.heading_from_gyro, fused);
  EXPECT_EQ(s.gyro_epochs, readings);
  ASSERT_TRUE(s.gyro.has_value());
  EXPECT_EQ(s.gyro->bias, last.bias);
  EXPECT_EQ(s.gyro->bias_sd, last.bias_sd);
  EXPECT_EQ(s.gyro->scale, last.scale);
  EXPECT_THAT(s.text(), HasSubstr(s.gyro_line()));
}

TEST(GyroSummary, TheReportShowsTheHeadingFromTheGyroOfDiagnosticsCsv) {
  const fs::path& log = gyro_log();
  const fs::path dir = test::scratch_dir("gyro-summary-report");
  const fs::path out = dir / "odometry.csv", diagnostics = dir / "diagnostics.csv";
  const std::string config = (log / "robot.yaml").string();
  ASSERT_EQ(test::run_moa("odometry --config " + config + " --log " + log.string() + " --out " +
                          out.string() + " --diagnostics " + diagnostics.string())
                .exit_code,
            0);
  const DiagnosticsCounts d = count_diagnostics(diagnostics);
  const std::string report = "report --config " + config + " --log " + log.string() +
                             " --odometry " + out.string() + " --out ";
  ASSERT_EQ(
      test::run_moa(report + (dir / "r.html").string() + " --diagnostics " + diagnostics.string())
          .exit_code,
      0);
  const std::string page = test::read_text(dir / "r.html");
  EXPECT_THAT(page, HasSubstr("<section id=\"gyro\">"));
  EXPECT_THAT(page, HasSubstr(fmt::format("<tr><th>heading from the gyro</th><td>{} of {} epochs",
                                          d.fused, d.epochs)));
  EXPECT_THAT(page, HasSubstr(fmt::format("<tr><th>gyro readings</th><td>{} epochs", d.imu)));
  EXPECT_THAT(page, HasSubstr(fmt::format("in {} epochs (", d.over)));
  // The gyro's calibration after the last epoch, from the last imu row.
  EXPECT_THAT(page, HasSubstr(fmt::format(
                        "<tr><th>calibration at the end</th><td>bias {:.6f} rad/s, scale {:.5f}",
                        std::stod(d.last_bias), std::stod(d.last_scale))));
  // Without diagnostics.csv: the section says how to get it.
  ASSERT_EQ(test::run_moa(report + (dir / "bare.html").string()).exit_code, 0);
  const std::string bare = test::read_text(dir / "bare.html");
  EXPECT_THAT(bare, HasSubstr("<section id=\"gyro\">"));
  EXPECT_THAT(bare, HasSubstr("--diagnostics DIAGNOSTICS.csv"));
  fs::remove_all(dir);
}

/// The dashboard fed the run's steps: a client joining after the end gets
/// the final state, whose heading and gyro are the last epoch's.
TEST(GyroSummary, TheDashboardsLastEventHasTheLastEpochsHeadingAndGyro) {
  const fs::path& log = gyro_log();
  const std::string config_path = (log / "robot.yaml").string();
  const RobotConfig config = read_config(config_path);
  const OdometryOptions options =
      resolve_odometry_options({}, "consensus", {}, false, config, config_path);
  DashboardOptions dashboard_options;
  dashboard_options.port = 0;
  Dashboard dashboard(config, dashboard_options);
  std::string last_heading;
  const OdometryRun run =
      run_odometry(config, config_path, resolve_log(log), options, [&](const OdometryStep& s) {
        last_heading = s.estimate.tests.gyro_fused ? "gyro" : to_name(s.estimate.source);
        dashboard.publish(s);
      });
  dashboard.finish();
  const auto stream = test::http_get(dashboard.port(), "/events", 2.0);
  ASSERT_EQ(stream.status, 200);
  // The final state: the last "data:" line of a default event.
  std::string last;
  std::istringstream in(stream.body);
  std::string line, event;
  while (std::getline(in, line)) {
    if (line.rfind("event:", 0) == 0) event = line;
    if (line.empty()) event.clear();
    if (line.rfind("data: ", 0) == 0 && event.empty()) last = line;
  }
  ASSERT_FALSE(last.empty()) << stream.body;
  EXPECT_THAT(last, HasSubstr("\"heading\": \"" + last_heading + "\""));
  ASSERT_TRUE(run.summary.gyro.has_value());
  EXPECT_THAT(last, HasSubstr(fmt::format("\"gyro\": {{\"bias\": {}", run.summary.gyro->bias)));
  EXPECT_THAT(last, HasSubstr(fmt::format("\"scale\": {}", run.summary.gyro->scale)));
}

}  // namespace
}  // namespace moa::io
