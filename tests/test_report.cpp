// moa report: the page is one self-contained file with every section, its
// plotted series agree with quantities computed here from the files, and
// bad inputs fail with a precise one-line error and no output file.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <numbers>
#include <sstream>

#include "moa/formats/config.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/log.hpp"
#include "moa/web/report.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

// Rated max_speed (m/s) of sensors a, b, c, d; mixed_motion's point speeds
// reach ~0.45. b's is low so that its exclusions also carry "/over-speed".
constexpr std::array<double, 4> kRatedSpeed{0.3, 0.2, 0.3, 0.3};
constexpr double kFaultStart = 4.0, kFaultEnd = 8.0;  // s, sensor b counts twice its motion

std::string slurp(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// A 12 s run: log with camera fixes, its odometry (consensus estimator),
/// and a calibration with every mount moved. Made once per test process,
/// removed at its exit.
struct ReportRun {
  fs::path dir;
  fs::path config, odometry, truth, calibration;
  std::string common;  ///< the report's flags without --truth, --calibration, --out
  ~ReportRun() {
    std::error_code ignored;
    if (!dir.empty()) fs::remove_all(dir, ignored);
  }
};

const ReportRun& report_run() {
  static const ReportRun r = [] {
    ReportRun out;
    out.dir = test::scratch_dir("report");
    const SensorArray array = test::skewed_array();
    // 1 ms integration substeps: the counts are within a count of the
    // exact ones, plenty for plots, and the log is made in a fraction of a second.
    auto log = test::synthesise(array, test::mixed_motion, 12.0, 0.01, true, 1e-3);
    for (auto& row : log.rows) {
      if (row.sensor == 1 && row.t > kFaultStart && row.t <= kFaultEnd) row.counts *= 2.0;
    }
    test::write_log(log, array, {"a", "b", "c", "d"}, out.dir);
    out.config = out.dir / "robot.yaml";
    io::RobotConfig config = io::read_config(out.config);
    for (int i = 0; i < config.array.size(); ++i)
      config.array[i].max_speed = kRatedSpeed[static_cast<std::size_t>(i)];
    io::write_config(config, out.config);
    for (int i = 0; i < config.array.size(); ++i) {
      config.array[i].position += Eigen::Vector2d(0.003, -0.002);
      config.array[i].yaw += 0.01;
    }
    out.calibration = out.dir / "cal.yaml";
    io::write_config(config, out.calibration);
    {
      std::ofstream camera(out.dir / "camera.csv");
      camera << "t,x,y\n";
      for (std::size_t k = 0; k < log.truth.size(); k += 10) {
        camera << log.truth[k].t << ',' << log.truth[k].pose.t.x() << ',' << log.truth[k].pose.t.y()
               << '\n';
      }
    }
    out.odometry = out.dir / "odom.csv";
    out.truth = out.dir / "truth.csv";
    const auto odometry = test::run_moa("odometry --config " + out.config.string() + " --log " +
                                        out.dir.string() + " --out " + out.odometry.string());
    EXPECT_EQ(odometry.exit_code, 0) << odometry.err;
    out.common = "report --config " + out.config.string() + " --log " + out.dir.string() +
                 " --odometry " + out.odometry.string();
    return out;
  }();
  return r;
}

io::ReportInputs inputs_of(const ReportRun& r) {
  io::ReportInputs in;
  in.config = r.config;
  in.log = r.dir;
  in.odometry = r.odometry;
  in.truth = r.truth;
  in.calibration = r.calibration;
  return in;
}

/// odometry.csv as this test reads it: every column by name, as text.
std::vector<std::map<std::string, std::string>> read_odometry(const fs::path& file) {
  std::ifstream in(file);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header;
  std::stringstream h(line);
  for (std::string f; std::getline(h, f, ',');) header.push_back(f);
  std::vector<std::map<std::string, std::string>> rows;
  while (std::getline(in, line)) {
    std::map<std::string, std::string> row;
    std::size_t start = 0;
    for (const auto& name : header) {
      const std::size_t end = std::min(line.find(',', start), line.size());
      row[name] = line.substr(start, end - start);
      start = end + 1;
    }
    rows.push_back(row);
  }
  return rows;
}

/// The state of sensor `name` in one row: "used", its reason, or "absent".
std::string state_of(const std::map<std::string, std::string>& row, const std::string& name) {
  std::stringstream used(row.at("used"));
  for (std::string s; std::getline(used, s, '+');) {
    if (s == name) return "used";
  }
  std::stringstream excluded(row.at("excluded"));
  for (std::string e; std::getline(excluded, e, ';');) {
    if (e.rfind(name + ":", 0) == 0) return e.substr(name.size() + 1);
  }
  return "absent";
}

/// The plotted bin that holds the row at time t: the first whose last row is at or after t.
const io::ReportBin& bin_of(const io::ReportModel& m, double t) {
  const auto it = std::lower_bound(m.bins.begin() + 1, m.bins.end(), t,
                                   [](const io::ReportBin& b, double time) { return b.t < time; });
  return *it;
}

TEST(Report, PageIsOneSelfContainedFileWithEverySection) {
  const ReportRun& r = report_run();
  const fs::path out_dir = test::scratch_dir("report-page");
  const fs::path page_file = out_dir / "report.html";
  const auto result = test::run_moa(r.common + " --truth " + r.truth.string() + " --calibration " +
                                    r.calibration.string() + " --out " + page_file.string());
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_THAT(result.out, HasSubstr("report.html"));
  // One file: no temporary left beside it.
  EXPECT_EQ(std::distance(fs::directory_iterator(out_dir), fs::directory_iterator{}), 1);
  const std::string page = slurp(page_file);
  // Nothing outside the page: no web address at all, no attribute that loads anything.
  EXPECT_EQ(page.find("http://"), std::string::npos);
  EXPECT_EQ(page.find("https://"), std::string::npos);
  EXPECT_EQ(page.find(" src="), std::string::npos);
  EXPECT_EQ(page.find(" href="), std::string::npos);
  EXPECT_EQ(page.find("<link"), std::string::npos);
  EXPECT_EQ(page.find("@import"), std::string::npos);
  for (const char* id : {"summary", "trajectory", "errors", "timeline", "speed", "sensors",
                         "layout", "calibration", "chart-trajectory", "chart-errors",
                         "chart-timeline", "chart-speed", "chart-layout", "moa-data"}) {
    EXPECT_THAT(page, HasSubstr(std::string("id=\"") + id + "\"")) << id;
  }
  EXPECT_THAT(page, HasSubstr("Chart.js v3"));  // the library is inlined
  EXPECT_THAT(page, HasSubstr("<html"));
  EXPECT_THAT(page, HasSubstr("</html>"));
  // 1200 epochs, each series at most 2000 points: well under a megabyte with the library.
  EXPECT_LT(page.size(), 1'000'000u);
  if (!HasFailure()) fs::remove_all(out_dir);
}

// A calibration against a camera writes latencies (docs/formats/config.md):
// the calibration section shows each sensor's and the camera's, before and after.
TEST(Report, CalibrationSectionShowsTheLatencies) {
  const ReportRun& r = report_run();
  const fs::path out_dir = test::scratch_dir("report-latency");
  io::RobotConfig cal = io::read_config(r.calibration);
  std::vector<SensorMount> mounts(cal.array.mounts().begin(), cal.array.mounts().end());
  mounts[0].latency = 0.0042;
  cal.array = SensorArray(mounts);
  cal.camera_latency = 0.012;
  io::write_config(cal, out_dir / "cal.yaml");
  const fs::path page_file = out_dir / "report.html";
  const auto result = test::run_moa(r.common + " --calibration " + (out_dir / "cal.yaml").string() +
                                    " --out " + page_file.string());
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const std::string page = slurp(page_file);
  EXPECT_THAT(page, HasSubstr("<th>latency (ms)</th>"));
  EXPECT_THAT(page, HasSubstr("<td>0.00 &rarr; 4.20</td>"));
  EXPECT_THAT(page, HasSubstr("camera latency: not set &rarr; 12.00 ms"));
  EXPECT_EQ(page.find("wheels latency"), std::string::npos);
  if (!HasFailure()) fs::remove_all(out_dir);
}

TEST(Report, SummaryGivesMillimetresOverTheTruthsDistanceAndAVerdict) {
  const ReportRun& r = report_run();
  const io::ReportModel m = io::build_report(inputs_of(r), {.max_points = 200});
  ASSERT_TRUE(m.errors.has_value());
  ASSERT_TRUE(m.floor.has_value());
  // The truth's path length, summed here from truth.csv (the odometry runs to its end).
  double distance = 0.0;
  const auto truth = io::read_all<io::TruthRow>(r.truth);
  for (std::size_t k = 1; k < truth.size(); ++k)
    distance += (truth[k].pose.t - truth[k - 1].pose.t).norm();
  EXPECT_NEAR(m.errors->distance, distance, 1e-9 * distance);
  // Sensor b counts double for a while: far above what rounding alone gives.
  EXPECT_GT(m.errors->max_translation, 2.0 * m.floor->max_translation);
  const std::string page = io::render_report(m);
  char travelled[64];
  std::snprintf(travelled, sizeof travelled, "mm over %.3g m travelled", distance);
  EXPECT_THAT(page, HasSubstr(travelled));
  EXPECT_THAT(page, HasSubstr("<tr class=\"verdict\"><th>verdict</th><td>"));
  EXPECT_THAT(page, HasSubstr("x the quantisation floor"));
}

TEST(Report, WithoutTruthOrCalibrationTheirSectionsSayWhatToAdd) {
  const ReportRun& r = report_run();
  const fs::path out_dir = test::scratch_dir("report-plain");
  const auto result = test::run_moa(r.common + " --out " + (out_dir / "r.html").string());
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const std::string page = slurp(out_dir / "r.html");
  EXPECT_THAT(page, HasSubstr("--truth TRUTH.csv"));
  EXPECT_EQ(page.find("id=\"chart-errors\""), std::string::npos);
  EXPECT_EQ(page.find("id=\"calibration\""), std::string::npos);
  EXPECT_THAT(page, HasSubstr("id=\"chart-layout\""));
  fs::remove_all(out_dir);
}

TEST(Report, LongRunsAreBinnedToMaxPoints) {
  io::ReportOptions options;
  options.max_points = 100;
  const io::ReportModel m = io::build_report(inputs_of(report_run()), options);
  const auto rows = read_odometry(report_run().odometry);
  ASSERT_GT(rows.size(), 10 * options.max_points);
  EXPECT_EQ(m.epochs, rows.size());
  EXPECT_LE(m.bins.size(), options.max_points);
  EXPECT_LE(m.truth.size(), options.max_points);
  EXPECT_LE(m.camera.size(), options.max_points);
  // The start and the end are kept, and the bins are in time order.
  EXPECT_EQ(m.bins.front().t, std::stod(rows.front().at("t")));
  EXPECT_EQ(m.bins.back().t, std::stod(rows.back().at("t")));
  EXPECT_EQ(m.bins.back().pose.t.x(), std::stod(rows.back().at("x")));
  for (std::size_t k = 1; k < m.bins.size(); ++k) EXPECT_LT(m.bins[k - 1].t, m.bins[k].t);
}

TEST(Report, ErrorAndSpeedBinsHoldTheLargestValueOfTheirRows) {
  const io::ReportModel m = io::build_report(inputs_of(report_run()), {.max_points = 300});
  const auto rows = read_odometry(report_run().odometry);
  const auto truth = io::read_all<io::TruthRow>(report_run().truth);
  const io::RobotConfig config = io::read_config(report_run().config);
  // Errors: truth interpolated linearly here (rows are time-sorted).
  double max_translation = 0.0, max_heading = 0.0;
  std::array<double, 4> max_speed{};
  std::size_t over_rated = 0;
  for (const auto& row : rows) {
    const double t = std::stod(row.at("t"));
    const auto after =
        std::find_if(truth.begin(), truth.end(), [t](const auto& s) { return s.t >= t; });
    ASSERT_NE(after, truth.end());
    const auto before = after == truth.begin() ? after : after - 1;
    const double f = after->t == before->t ? 0.0 : (t - before->t) / (after->t - before->t);
    const double tx = before->pose.t.x() + f * (after->pose.t.x() - before->pose.t.x());
    const double ty = before->pose.t.y() + f * (after->pose.t.y() - before->pose.t.y());
    const double th = before->pose.theta + f * (after->pose.theta - before->pose.theta);
    const double dp = std::hypot(std::stod(row.at("x")) - tx, std::stod(row.at("y")) - ty);
    const double dh =
        std::abs(std::remainder(std::stod(row.at("theta")) - th, 2 * std::numbers::pi));
    const io::ReportBin& bin = bin_of(m, t);
    // Reading the same files, only rounding of the interpolation differs.
    EXPECT_LE(dp, bin.translation_error + 1e-12) << t;
    EXPECT_LE(dh, bin.heading_error + 1e-12) << t;
    max_translation = std::max(max_translation, dp);
    max_heading = std::max(max_heading, dh);
    const double vx = std::stod(row.at("vx")), vy = std::stod(row.at("vy"));
    const double w = std::stod(row.at("omega"));
    for (int i = 0; i < 4; ++i) {
      const Eigen::Vector2d p = config.array[i].position;
      const double s = std::hypot(vx - w * p.y(), vy + w * p.x());  // |v + omega J p|
      EXPECT_LE(s, bin.speed[static_cast<std::size_t>(i)] + 1e-12) << t;
      max_speed[static_cast<std::size_t>(i)] = std::max(max_speed[static_cast<std::size_t>(i)], s);
      if (s > kRatedSpeed[static_cast<std::size_t>(i)]) ++over_rated;
    }
  }
  double bins_translation = 0.0, bins_heading = 0.0;
  std::array<double, 4> bins_speed{};
  for (const auto& b : m.bins) {
    bins_translation = std::max(bins_translation, b.translation_error);
    bins_heading = std::max(bins_heading, b.heading_error);
    for (std::size_t i = 0; i < 4; ++i) bins_speed[i] = std::max(bins_speed[i], b.speed[i]);
  }
  EXPECT_NEAR(bins_translation, max_translation, 1e-12);
  EXPECT_NEAR(bins_heading, max_heading, 1e-12);
  ASSERT_TRUE(m.errors);
  EXPECT_NEAR(m.errors->max_translation, max_translation, 1e-12);
  std::size_t report_over_rated = 0;
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_NEAR(bins_speed[i], max_speed[i], 1e-12);
    EXPECT_NEAR(m.sensors[i].max_speed, max_speed[i], 1e-12);
    report_over_rated += m.sensors[i].over_rated;
  }
  EXPECT_EQ(report_over_rated, over_rated);
  EXPECT_GT(over_rated, 0u);  // the run does exceed the rated speed
}

TEST(Report, TimelineShowsTheFaultySensorExcludedWithItsReason) {
  const io::ReportModel m = io::build_report(inputs_of(report_run()), {.max_points = 400});
  const auto rows = read_odometry(report_run().odometry);
  ASSERT_TRUE(m.has_selection);
  // The segments of a row that hold time t (two where t is on a bin edge;
  // 1 ns of slack for the rounding of the edges).
  const auto segments_at = [&m](int row, double t) {
    std::vector<const io::TimelineSegment*> out;
    for (const auto& s : m.timeline) {
      if (s.row == row && s.t0 <= t + 1e-9 && t <= s.t1 + 1e-9) out.push_back(&s);
    }
    return out;
  };
  // Every epoch of every sensor lies in a segment; where a segment's share is
  // 1, the epoch's state (read here from odometry.csv) is the segment's.
  std::map<std::string, std::size_t> excluded_b;
  std::size_t fault_epochs = 0, fault_excluded = 0;
  for (const auto& row : rows) {
    const double t = std::stod(row.at("t"));
    for (int i = 0; i < 4; ++i) {
      const std::string state = state_of(row, m.config.names[static_cast<std::size_t>(i)]);
      const auto candidates = segments_at(i, t);
      ASSERT_FALSE(candidates.empty()) << "sensor " << i << " t " << t;
      EXPECT_TRUE(std::any_of(candidates.begin(), candidates.end(),
                              [&](const auto* s) {
                                return s->share < 1.0 ||
                                       m.states[static_cast<std::size_t>(s->state)] == state;
                              }))
          << "sensor " << i << " t " << t << " state " << state;
      if (i == 1 && state != "used") ++excluded_b[state];
    }
    if (t > kFaultStart + 0.1 && t <= kFaultEnd) {
      ++fault_epochs;
      if (state_of(row, "b") != "used") ++fault_excluded;
    }
  }
  // The doubled counts of b contradict the rigid motion the other three
  // agree on: each epoch's test rejects them (`inconsistent`); where b is
  // under its rating the drift test's statistic alarms within a few epochs
  // too (`drift`, the named outcome of a persistent shift).
  EXPECT_GT(fault_excluded, 9 * fault_epochs / 10);
  EXPECT_GT(excluded_b["drift"] + excluded_b["drift/over-speed"], 0u);
  const auto mids = segments_at(1, 0.5 * (kFaultStart + kFaultEnd) + 1e-3);
  ASSERT_EQ(mids.size(), 1u);
  const io::TimelineSegment* mid = mids.front();
  EXPECT_EQ(m.states[static_cast<std::size_t>(mid->state)].substr(0, 12), "inconsistent");
  // The per-sensor counts are the same as counted here.
  const io::SensorSummary& b = m.sensors[1];
  std::size_t total = b.used;
  for (std::size_t k = 0; k < m.states.size(); ++k) {
    total += b.excluded[k];
    const auto it = excluded_b.find(m.states[k]);
    EXPECT_EQ(b.excluded[k], it == excluded_b.end() ? 0u : it->second) << m.states[k];
  }
  EXPECT_EQ(total, rows.size());
  EXPECT_GT(excluded_b["inconsistent/over-speed"], 0u);
  for (const auto& [state, count] : excluded_b) {
    EXPECT_NE(std::find(m.states.begin(), m.states.end(), state), m.states.end()) << state;
  }
}

TEST(Report, CalibratedMountsComeInTheConfigsOrder) {
  const ReportRun& r = report_run();
  // The same sensors listed in reverse order.
  io::RobotConfig cal = io::read_config(r.calibration);
  std::reverse(cal.names.begin(), cal.names.end());
  std::vector<SensorMount> mounts(cal.array.mounts().rbegin(), cal.array.mounts().rend());
  cal.array = SensorArray(mounts);
  const fs::path reversed = r.dir / "cal-reversed.yaml";
  io::write_config(cal, reversed);
  io::ReportInputs in = inputs_of(r);
  in.calibration = reversed;
  const io::ReportModel m = io::build_report(in, {.max_points = 50});
  ASSERT_TRUE(m.calibrated);
  const io::RobotConfig expected = io::read_config(r.calibration);
  EXPECT_EQ(m.calibrated->names, expected.names);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(m.calibrated->array[i].position, expected.array[i].position);
    EXPECT_EQ(m.calibrated->array[i].yaw, expected.array[i].yaw);
  }
}

// --self-calibration: the estimates of `moa odometry --self-calibration` are
// plotted per sensor over time, each series the file's rows of that sensor
// (read here line by line); without the input there is no such section.
TEST(Report, SelfCalibrationIsPlottedPerSensorOverTime) {
  const ReportRun& r = report_run();
  const fs::path dir = test::scratch_dir("report-self-calibration");
  const fs::path cal = dir / "self-calibration.csv";
  const auto odometry =
      test::run_moa("odometry --quiet --config " + r.config.string() + " --log " + r.dir.string() +
                    " --out " + (dir / "o.csv").string() + " --self-calibration " + cal.string());
  ASSERT_EQ(odometry.exit_code, 0) << odometry.err;
  std::map<std::string, std::vector<std::vector<double>>> rows;  // sensor -> t, sx, sy
  {
    std::ifstream in(cal);
    std::string line;
    std::getline(in, line);
    ASSERT_EQ(line,
              "t,sensor,scale_x,scale_y,yaw_offset,filter_scale_x,filter_scale_y,"
              "filter_yaw_offset,filter_sd_scale_x,filter_sd_scale_y,filter_sd_yaw_offset");
    while (std::getline(in, line)) {
      // The chart shows the filter's estimates (filter_scale_x and _y).
      std::stringstream ss(line);
      std::string t, name, f[5];
      std::getline(ss, t, ',');
      std::getline(ss, name, ',');
      for (auto& x : f) std::getline(ss, x, ',');
      rows[name].push_back({std::stod(t), std::stod(f[3]), std::stod(f[4])});
    }
  }
  io::ReportInputs in = inputs_of(r);
  in.self_calibration = cal;
  const io::ReportModel m = io::build_report(in);
  ASSERT_EQ(m.self_calibration.size(), 4u);
  for (int i = 0; i < 4; ++i) {
    const auto& series = m.self_calibration[static_cast<std::size_t>(i)];
    const auto& expected = rows[m.config.names[static_cast<std::size_t>(i)]];
    ASSERT_EQ(series.t.size(), expected.size()) << i;
    ASSERT_GE(series.t.size(), 12u) << "12 s: about once a second";
    for (std::size_t k = 0; k < expected.size(); ++k) {
      EXPECT_EQ(series.t[k], expected[k][0]);
      EXPECT_EQ(series.scale_x[k], expected[k][1]);
      EXPECT_EQ(series.scale_y[k], expected[k][2]);
    }
  }
  const std::string page = io::render_report(m);
  EXPECT_THAT(page, HasSubstr("id=\"self-calibration\""));
  EXPECT_THAT(page, HasSubstr("<canvas id=\"chart-self-calibration\">"));
  EXPECT_THAT(page, HasSubstr("\"self_calibration\":[{\"t\":["));
  const std::string without = io::render_report(io::build_report(inputs_of(r)));
  EXPECT_EQ(without.find("<canvas id=\"chart-self-calibration\">"), std::string::npos);
  EXPECT_EQ(without.find("id=\"self-calibration\""), std::string::npos);
  EXPECT_THAT(without, HasSubstr("\"self_calibration\":null"));
}

TEST(Report, OdometryWithoutSelectionColumnsIsPlottedWithoutTimeline) {
  const ReportRun& r = report_run();
  const fs::path dir = test::scratch_dir("report-plain-odometry");
  {
    std::ifstream in(r.odometry);
    std::ofstream out(dir / "odom.csv");
    for (std::string line; std::getline(in, line);) {
      std::size_t end = 0;
      for (int commas = 0; commas < 7 && end != std::string::npos; ++commas) {
        end = line.find(',', end == 0 ? 0 : end + 1);
      }
      out << line.substr(0, end) << '\n';  // t,x,y,theta,vx,vy,omega
    }
  }
  io::ReportInputs in = inputs_of(r);
  in.odometry = dir / "odom.csv";
  in.log = r.dir / "mice.csv";  // the log named by its mice.csv, as `moa odometry` allows
  const io::ReportModel m = io::build_report(in, {.max_points = 100});
  EXPECT_FALSE(m.has_selection);
  EXPECT_TRUE(m.timeline.empty());
  EXPECT_EQ(m.epochs, read_odometry(r.odometry).size());
  EXPECT_EQ(m.camera_rows, 121u);  // camera.csv beside mice.csv: 12 s at 10 Hz and t = 0
  const std::string page = io::render_report(m);
  EXPECT_THAT(page, HasSubstr("has no <code>used</code>"));
  EXPECT_EQ(page.find("id=\"chart-timeline\""), std::string::npos);
  fs::remove_all(dir);
}

struct BadInput {
  const char* name;
  /// Prepares the case in `dir` (a copy of the run's files) and returns the flags.
  std::function<std::string(const fs::path& dir)> setup;
  const char* error;  ///< expected in the one line on stderr
};

std::string flags(const fs::path& d, const std::string& odometry = "odom.csv",
                  const std::string& extra = "") {
  return "report --config " + (d / "robot.yaml").string() + " --log " + d.string() +
         " --odometry " + (d / odometry).string() + extra;
}

void write_file(const fs::path& file, const std::string& text) {
  std::ofstream out(file);
  out << text;
}

/// odom.csv with its third line's `used` field replaced.
void replace_first_used(const fs::path& dir, const std::string& used) {
  auto text = slurp(dir / "odom.csv");
  std::istringstream in(text);
  std::string header, first, second, rest;
  std::getline(in, header);
  std::getline(in, first);
  std::getline(in, second);
  std::stringstream tail;
  tail << in.rdbuf();
  std::vector<std::string> fields;
  std::stringstream s(second);
  for (std::string f; std::getline(s, f, ',');) fields.push_back(f);
  if (second.back() == ',') fields.push_back("");
  std::stringstream hs(header);
  std::size_t k = 0;
  for (std::string name; std::getline(hs, name, ','); ++k) {
    if (name == "used") fields[k] = used;
  }
  std::string line;
  for (std::size_t i = 0; i < fields.size(); ++i) line += (i ? "," : "") + fields[i];
  write_file(dir / "odom.csv", header + "\n" + first + "\n" + line + "\n" + tail.str());
}

class ReportBadInput : public ::testing::TestWithParam<BadInput> {};

TEST_P(ReportBadInput, FailsWithOneLineAndNoPage) {
  const ReportRun& r = report_run();
  const fs::path dir = test::scratch_dir("report-bad");
  for (const auto& entry : fs::directory_iterator(r.dir)) {
    fs::copy(entry.path(), dir / entry.path().filename());
  }
  const std::string args = GetParam().setup(dir);
  const fs::path out = dir / "out" / "report.html";
  fs::create_directories(out.parent_path());
  const auto result = test::run_moa(args + " --out " + out.string());
  EXPECT_NE(result.exit_code, 0);
  EXPECT_THAT(result.err, HasSubstr(GetParam().error));
  EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;
  EXPECT_TRUE(fs::is_empty(out.parent_path())) << "a page or a temporary was left behind";
  if (!HasFailure()) fs::remove_all(dir);
}

const BadInput kBadInputs[] = {
    {"MissingOdometry", [](const fs::path& d) { return flags(d, "nope.csv"); },
     "nope.csv: cannot open"},
    {"MissingLogDirectory",
     [](const fs::path& d) {
       return "report --config " + (d / "robot.yaml").string() + " --log " +
              (d / "nolog").string() + " --odometry " + (d / "odom.csv").string();
     },
     "nolog: no such log directory"},
    {"MissingConfig",
     [](const fs::path& d) {
       fs::remove(d / "robot.yaml");
       return flags(d);
     },
     "robot.yaml: cannot open"},
    {"MissingTruth",
     [](const fs::path& d) { return flags(d, "odom.csv", " --truth " + (d / "t.csv").string()); },
     "t.csv: cannot open"},
    {"MiceNamesNotInConfig",
     [](const fs::path& d) {
       io::RobotConfig c = io::read_config(d / "robot.yaml");
       c.names = {"w", "x", "y", "z"};
       io::write_config(c, d / "robot.yaml");
       return flags(d);
     },
     "mice.csv:3: unknown sensor 'a'"},
    {"OdometryNamesNotInConfig",
     [](const fs::path& d) {
       replace_first_used(d, "a+zz");
       return flags(d);
     },
     "odom.csv:3: column 'used': unknown sensor 'zz'"},
    {"SensorBothUsedAndExcluded",
     [](const fs::path& d) {
       auto text = slurp(d / "odom.csv");
       const auto second_line = text.find('\n', text.find('\n') + 1) + 1;
       const auto end = text.find('\n', second_line);
       std::string line = text.substr(second_line, end - second_line);
       line = line.substr(0, line.rfind(',') + 1) + "a:lift";  // excluded is the last column
       write_file(d / "odom.csv", text.substr(0, second_line) + line + text.substr(end));
       return flags(d);
     },
     "odom.csv:3: column 'excluded': sensor 'a' is listed twice"},
    {"ExcludedEntryWithoutReason",
     [](const fs::path& d) {
       replace_first_used(d, "a+b+c");
       auto text = slurp(d / "odom.csv");
       const auto second_line = text.find('\n', text.find('\n') + 1) + 1;
       const auto end = text.find('\n', second_line);
       std::string line = text.substr(second_line, end - second_line);
       line = line.substr(0, line.rfind(',') + 1) + "d";
       write_file(d / "odom.csv", text.substr(0, second_line) + line + text.substr(end));
       return flags(d);
     },
     "odom.csv:3: column 'excluded': 'd' is not name:reason"},
    {"OdometryWithoutTwist",
     [](const fs::path& d) {
       write_file(d / "o2.csv", "t,x,y,theta,vx,vy\n0,0,0,0,0,0\n");
       return flags(d, "o2.csv");
     },
     "o2.csv:1: missing column 'omega'"},
    {"OdometryWithoutRows",
     [](const fs::path& d) {
       write_file(d / "o3.csv", "t,x,y,theta,vx,vy,omega\n");
       return flags(d, "o3.csv");
     },
     "o3.csv: has no rows"},
    {"TruthOfAnotherTime",
     [](const fs::path& d) {
       write_file(d / "late.csv", "t,x,y,theta\n100,0,0,0\n101,0,0,0\n");
       return flags(d, "odom.csv", " --truth " + (d / "late.csv").string());
     },
     "no row lies within the time span of"},
    {"CalibrationMissingASensor",
     [](const fs::path& d) {
       io::RobotConfig c = io::read_config(d / "cal.yaml");
       c.names.pop_back();
       std::vector<SensorMount> m(c.array.mounts().begin(), c.array.mounts().end());
       m.pop_back();
       c.array = SensorArray(m);
       io::write_config(c, d / "cal.yaml");
       return flags(d, "odom.csv", " --calibration " + (d / "cal.yaml").string());
     },
     "cal.yaml: has no sensor 'd' of"},
    {"SelfCalibrationWithAnotherSensor",
     [](const fs::path& d) {
       write_file(d / "sc.csv", "t,sensor,scale_x,scale_y,yaw_offset\n0,a,1,1,0\n0,e,1,1,0\n");
       return flags(d, "odom.csv", " --self-calibration " + (d / "sc.csv").string());
     },
     "sc.csv: sensor 'e' is not in"},
    {"SelfCalibrationWithABadScale",
     [](const fs::path& d) {
       write_file(d / "sc.csv", "t,sensor,scale_x,scale_y,yaw_offset\n0,a,1,1,0\n1,a,1,-2,0\n");
       return flags(d, "odom.csv", " --self-calibration " + (d / "sc.csv").string());
     },
     "sc.csv:3: column 'scale_y': must be > 0"},
    {"CalibrationWithAnotherSensor",
     [](const fs::path& d) {
       io::RobotConfig c = io::read_config(d / "cal.yaml");
       c.names.back() = "e";
       io::write_config(c, d / "cal.yaml");
       return flags(d, "odom.csv", " --calibration " + (d / "cal.yaml").string());
     },
     "cal.yaml: sensor 'e' is not in"},
};

INSTANTIATE_TEST_SUITE_P(Report, ReportBadInput, ::testing::ValuesIn(kBadInputs),
                         [](const auto& p) { return std::string(p.param.name); });

TEST(Report, UnwritableOutputIsAnError) {
  const ReportRun& r = report_run();
  const auto result =
      test::run_moa(r.common + " --out " + (r.dir / "no" / "such" / "r.html").string());
  EXPECT_NE(result.exit_code, 0);
  EXPECT_THAT(result.err, HasSubstr("r.html: cannot open for writing"));
  EXPECT_FALSE(fs::exists(r.dir / "no"));
}

}  // namespace
}  // namespace moa
