// Online self-calibration from the command line (docs/self-calibration.md):
// a sensor configured with a resolution 25 % and more off is reported and
// excluded as `calibration` by `moa odometry --self-calibrate`; `moa live
// --self-calibration FILE.csv` writes the documented file about once a
// second; the self-calibration.csv reader refuses bad rows with the line.
// Simulated logs on the test seeds 101-103 (the thresholds were tuned on
// seeds 1-100).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "moa/formats/error.hpp"
#include "moa/formats/self_calibration_csv.hpp"
#include "moa/sim/scenario.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

std::vector<std::string> split(const std::string& line, char sep) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  std::string field;
  while (std::getline(ss, field, sep)) out.push_back(field);
  if (!line.empty() && line.back() == sep) out.emplace_back();
  return out;
}

/// Rows of a CSV file without its header (and without '#' comment lines).
std::vector<std::vector<std::string>> rows_of(const fs::path& file, std::string* header = nullptr) {
  std::ifstream in(file);
  std::string line;
  std::vector<std::vector<std::string>> rows;
  bool first = true;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (first) {
      if (header) *header = line;
      first = false;
      continue;
    }
    rows.push_back(split(line, ','));
  }
  return rows;
}

/// sekimori-a (Table 3 path at speed (a), four HDNS-2051 configured at 800
/// cpi) with sensor m2 built as `m2_truth` (a true_sensors entry's fields).
std::string misconfigured_scenario(const std::string& m2_truth) {
  std::string yaml(sim::builtin_scenario_text("sekimori-a"));
  const std::string m2 =
      "  m2: {position_error: [-0.0002, 0.0001], yaw_error: -0.0017, scale: [1.001, 0.9995]}";
  const auto at = yaml.find(m2);
  EXPECT_NE(at, std::string::npos) << "sekimori-a's m2 line changed";
  if (at != std::string::npos) yaml.replace(at, m2.size(), "  m2: {" + m2_truth + "}");
  return yaml;
}

std::string built_at_cpi(int true_cpi) {
  return "position_error: [-0.0002, 0.0001], yaw_error: -0.0017, cpi: " + std::to_string(true_cpi);
}

struct RunawayRun {
  std::string err;                    ///< moa odometry's stderr
  std::vector<std::string> excluded;  ///< odometry.csv's `excluded`, row by row
  std::vector<double> t;
  std::vector<io::SelfCalibrationRow> calibration;  ///< self-calibration.csv
  double max_error = NAN;                           ///< m, moa evaluate's against truth.csv
};

/// moa evaluate's max translation error (m) of `odometry` against `truth`.
double max_error(const fs::path& truth, const fs::path& odometry) {
  const auto r = test::run_moa("evaluate --json --truth " + truth.string() + " --odometry " +
                               odometry.string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  std::smatch m;
  const std::regex key("\"max_translation_m\": ([0-9.eE+-]+)");
  if (!std::regex_search(r.out, m, key)) {
    ADD_FAILURE() << r.out;
    return NAN;
  }
  return std::stod(m[1]);
}

RunawayRun run_misconfigured(const std::string& m2_truth, int seed, bool self_calibrate) {
  const fs::path dir = test::scratch_dir("self-calibration-runaway");
  { std::ofstream(dir / "s.yaml") << misconfigured_scenario(m2_truth); }
  const std::string log = (dir / "log").string();
  const auto sim = test::run_moa("simulate --scenario " + (dir / "s.yaml").string() + " --seed " +
                                 std::to_string(seed) + " --out " + log);
  EXPECT_EQ(sim.exit_code, 0) << sim.err;
  const fs::path out = dir / "odometry.csv", cal = dir / "self-calibration.csv";
  const auto odo =
      test::run_moa("odometry --config " + log + "/robot.yaml --log " + log + " --out " +
                    out.string() + (self_calibrate ? " --self-calibration " + cal.string() : ""));
  EXPECT_EQ(odo.exit_code, 0) << odo.err;
  RunawayRun r;
  r.err = odo.err;
  std::string header;
  const auto rows = rows_of(out, &header);
  const auto columns = split(header, ',');
  EXPECT_EQ(columns.back(), "excluded") << header;
  for (const auto& row : rows) {
    EXPECT_EQ(row.size(), columns.size());
    if (row.size() != columns.size()) continue;
    r.t.push_back(std::stod(row.front()));
    r.excluded.push_back(row.back());
  }
  if (self_calibrate) r.calibration = io::read_self_calibration_csv(cal);
  r.max_error = max_error(fs::path(log) / "truth.csv", out);
  return r;
}

/// Checks that m2, and no other sensor, is reported once on stderr and
/// excluded as `calibration` from the epoch reported to the end, within the
/// first half of the run; returns the time it was reported.
double expect_m2_reported_and_excluded(const RunawayRun& r, int seed) {
  std::smatch m;
  const std::regex warning(
      "warning: sensor 'm2': its self-calibration ran away \\(scale [0-9.]+, [0-9.]+, yaw "
      "offset [-0-9.]+ rad at t = ([0-9.]+) s");
  if (!std::regex_search(r.err, m, warning)) {
    ADD_FAILURE() << seed << ": " << r.err;
    return NAN;
  }
  const double t_warned = std::stod(m[1]);
  EXPECT_EQ(r.err.find("ran away", m.position(0) + m.length(0)), std::string::npos)
      << "reported once: " << r.err;
  EXPECT_FALSE(r.t.empty());
  std::size_t first = r.t.size();
  for (std::size_t k = 0; k < r.t.size(); ++k) {
    for (const char* other : {"m1:calibration", "m3:calibration", "m4:calibration"}) {
      EXPECT_EQ(r.excluded[k].find(other), std::string::npos) << seed << " t " << r.t[k];
    }
    const bool out = r.excluded[k].find("m2:calibration") != std::string::npos;
    if (out && first == r.t.size()) first = k;
    if (first < k) {
      EXPECT_TRUE(out) << seed << " t " << r.t[k] << ": " << r.excluded[k];
    }
  }
  if (first == r.t.size()) {
    ADD_FAILURE() << seed << ": m2 never excluded as calibration";
    return t_warned;
  }
  EXPECT_DOUBLE_EQ(r.t[first], t_warned) << seed;
  // It runs away within the first lap's turns, not at the very end.
  EXPECT_LT(r.t[first], 0.5 * r.t.back()) << seed;
  return t_warned;
}

// m2 counts 1020/800 = 1.275 times what its config says: beyond the runaway
// bound of 25 % and under the 30 % relative residual above which a block is
// not used, so the estimate can get there. (The issue's 1000 cpi is exactly
// on the bound, where only the noise decides.) m2 is reported once, on
// stderr, with the time it ran away; from that epoch on it is excluded as
// `calibration` to the end (it comes back only within 0.8 times the bound,
// 20 %, and its truth stays 27.5 % off); no other sensor ever is.
//
// And the pose does not pay for it: the estimate walks from 1 to 1.275 over
// about 2 s before it runs away, and while it moves m2 is held out (a
// partial correction let it pass as consistent: 180 mm on seeds 1-3,
// against 3.5-5.2 mm for the consensus alone, which leaves m2 out as
// inconsistent). Bound: the consensus alone's max error plus 5 mm, a few
// times the 1-2 mm that the max error of this path varies by over seeds
// (sekimori-a, docs/self-calibration.md).
TEST(SelfCalibrationCli, SensorConfiguredAQuarterOffIsReportedAndExcluded) {
  for (int seed = 101; seed <= 103; ++seed) {
    const RunawayRun r = run_misconfigured(built_at_cpi(1020), seed, true);
    expect_m2_reported_and_excluded(r, seed);
    const RunawayRun plain = run_misconfigured(built_at_cpi(1020), seed, false);
    EXPECT_LE(r.max_error, plain.max_error + 0.005) << seed;
  }
}

// --self-calibrate where it cannot learn says so (and runs): with the
// wheels estimator (no mice) and with fewer than three sensors (no
// redundancy); with three or more it says nothing.
TEST(SelfCalibrationCli, WarnsWhereItCannotLearn) {
  const fs::path dir = test::scratch_dir("self-calibration-warnings");
  const std::string log = (dir / "log").string();
  ASSERT_EQ(test::run_moa("simulate --scenario sekimori-a --seed 101 --out " + log).exit_code, 0);
  const std::string odometry = "odometry --config " + log + "/robot.yaml --log " + log + " --out " +
                               (dir / "o.csv").string() + " --self-calibrate ";
  const auto wheels = test::run_moa(odometry + "--estimator wheels");
  EXPECT_EQ(wheels.exit_code, 0) << wheels.err;
  EXPECT_THAT(wheels.err, HasSubstr("warning: --self-calibrate with --estimator wheels"));
  const auto two = test::run_moa(odometry + "--sensors m1,m2");
  EXPECT_EQ(two.exit_code, 0) << two.err;
  EXPECT_THAT(two.err, HasSubstr("warning: --self-calibrate with 2 sensor(s)"));
  const auto three = test::run_moa(odometry + "--sensors m1,m2,m3");
  EXPECT_EQ(three.exit_code, 0) << three.err;
  EXPECT_THAT(three.err, ::testing::Not(HasSubstr("--self-calibrate with")));
  const auto live = test::run_moa("live --config " + log + "/robot.yaml --replay " + log +
                                  " --speed 1000 --quiet --out " + (dir / "l.csv").string() +
                                  " --self-calibrate --sensors m1,m2");
  EXPECT_EQ(live.exit_code, 0) << live.err;
  EXPECT_THAT(live.err, HasSubstr("moa live: warning: --self-calibrate with 2 sensor(s)"));
}

// ls and sekimori use every sensor as their papers define them: a sensor
// whose calibration runs away could not be left out, so self-calibration
// with them is refused (a sensor built at 1020 cpi and configured at 800 cost
// 204 mm there against 2.9 mm with the consensus), and nothing is written.
// The oracle selects by the simulator's labels; the calibration's states are
// the consensus's: refused too.
TEST(SelfCalibrationCli, RefusedWithEstimatorsThatUseEverySensor) {
  const fs::path dir = test::scratch_dir("self-calibration-refused");
  const std::string log = (dir / "log").string();
  ASSERT_EQ(test::run_moa("simulate --scenario sekimori-a --seed 101 --out " + log).exit_code, 0);
  for (const std::string estimator : {"ls", "sekimori", "oracle"}) {
    const fs::path out = dir / (estimator + ".csv");
    const auto r =
        test::run_moa("odometry --config " + log + "/robot.yaml --log " + log + " --out " +
                      out.string() + " --self-calibrate --estimator " + estimator);
    EXPECT_EQ(r.exit_code, 1) << estimator;
    // Said whole, with the flags (it was cut at the option buffer's 191
    // characters and named the field).
    EXPECT_THAT(r.err, HasSubstr("--self-calibrate needs --estimator consensus, not " + estimator +
                                 ": ls and sekimori use every sensor"))
        << r.err;
    EXPECT_THAT(r.err, HasSubstr("not by tested hypotheses\n")) << r.err;
    EXPECT_FALSE(fs::exists(out)) << estimator;
  }
}

// Without --self-calibrate nothing is ever excluded as `calibration`.
TEST(SelfCalibrationCli, NoCalibrationReasonWithoutSelfCalibrate) {
  const RunawayRun r = run_misconfigured(built_at_cpi(1020), 101, false);
  EXPECT_THAT(r.err, ::testing::Not(HasSubstr("ran away")));
  for (const auto& e : r.excluded) EXPECT_EQ(e.find(":calibration"), std::string::npos) << e;
}

// Calibrations far off, whose blocks the gate rejects (docs/self-calibration.md
// "Gate and reset"): m2 built at 1200 cpi (counts 1.5 times the config's), at 560
// cpi (0.7 times), turned by 30 degrees (0.5236 rad), or 1.4 times on its x axis
// alone. The rejections alarm the CUSUM and the blocks agree with one calibration,
// so the filter is reset (said on stderr) and then runs away: reported, excluded as
// `calibration` to the end, as above. And the filter's final estimate is the truth: within the
// issue's 2 % on each scale (the good sensors' estimates scatter up to 1.2 % on cruise,
// docs/self-calibration.md) and 0.01 rad on the yaw offset (the true yaw errors of the other
// sensors, whose median is the gauge, differ from 0 by up to 0.0017 rad).
TEST(SelfCalibrationCli, CalibrationsFarOffAreResetReportedAndExcluded) {
  struct Case {
    std::string truth;
    double scale_x, scale_y, yaw;  ///< m2's truth relative to its config
  };
  const std::vector<Case> cases{
      {built_at_cpi(1200), 1.5, 1.5, -0.0017},
      {built_at_cpi(560), 0.7, 0.7, -0.0017},
      {"position_error: [-0.0002, 0.0001], yaw_error: 0.5236", 1.0, 1.0, 0.5236},
      {"position_error: [-0.0002, 0.0001], yaw_error: -0.0017, scale: [1.4, 1.0]", 1.4, 1.0,
       -0.0017}};
  for (const Case& c : cases) {
    for (int seed = 101; seed <= 103; ++seed) {
      SCOPED_TRACE(c.truth + ", seed " + std::to_string(seed));
      const RunawayRun r = run_misconfigured(c.truth, seed, true);
      expect_m2_reported_and_excluded(r, seed);
      // Found by the reset (its blocks rejected, agreeing with another
      // calibration), which is said; no other sensor is reset.
      EXPECT_THAT(r.err, HasSubstr("sensor 'm2': its self-calibration was reset at t = "));
      for (const char* other : {"'m1'", "'m3'", "'m4'"}) {
        EXPECT_THAT(r.err, Not(HasSubstr(std::string(other) + ": its self-calibration was reset")));
      }
      const RunawayRun plain = run_misconfigured(c.truth, seed, false);
      EXPECT_LE(r.max_error, plain.max_error + 0.005);  // as above
      const io::SelfCalibrationRow* last = nullptr;
      for (const auto& row : r.calibration) {
        if (row.sensor == "m2") last = &row;
      }
      ASSERT_NE(last, nullptr);
      EXPECT_NEAR(last->filter.scale_x / c.scale_x, 1.0, 0.02);
      EXPECT_NEAR(last->filter.scale_y / c.scale_y, 1.0, 0.02);
      EXPECT_NEAR(last->filter.yaw_offset, c.yaw, 0.01);
    }
  }
}

// moa live on a replayed log writes self-calibration.csv as
// docs/formats/log.md says: the header, then every selected sensor at the
// first epoch, at the first epoch at or after each whole second since it,
// and at the last epoch; the epochs are odometry.csv's (written by the same
// run). And it is what `moa odometry --self-calibration` writes for the log.
TEST(SelfCalibrationCli, LiveWritesTheEstimatesAboutOnceASecond) {
  const fs::path dir = test::scratch_dir("self-calibration-live");
  const std::string log = (dir / "log").string();
  ASSERT_EQ(test::run_moa("simulate --scenario faults-drift --seed 101 --out " + log).exit_code, 0);
  const fs::path cal = dir / "live-cal.csv", odometry = dir / "live.csv";
  const auto live = test::run_moa("live --config " + log + "/robot.yaml --replay " + log +
                                  " --speed 100 --quiet --out " + odometry.string() +
                                  " --self-calibration " + cal.string());
  ASSERT_EQ(live.exit_code, 0) << live.err;

  std::vector<double> epochs;
  for (const auto& row : rows_of(odometry)) epochs.push_back(std::stod(row.front()));
  ASSERT_GT(epochs.size(), 1000u);
  std::vector<double> due{epochs.front()};
  for (int k = 1; epochs.front() + k <= epochs.back() + 1e-9; ++k) {
    for (const double t : epochs) {
      if (t >= epochs.front() + k - 1e-9) {
        if (t != due.back()) due.push_back(t);
        break;
      }
    }
  }
  if (due.back() != epochs.back()) due.push_back(epochs.back());

  std::string header;
  const auto rows = rows_of(cal, &header);
  EXPECT_EQ(header,
            "t,sensor,scale_x,scale_y,yaw_offset,filter_scale_x,filter_scale_y,filter_yaw_offset,"
            "filter_sd_scale_x,filter_sd_scale_y,filter_sd_yaw_offset");
  const std::vector<std::string> names{"m1", "m2", "m3", "m4"};
  ASSERT_EQ(rows.size(), due.size() * names.size());
  for (std::size_t k = 0; k < rows.size(); ++k) {
    ASSERT_EQ(rows[k].size(), 11u);
    EXPECT_DOUBLE_EQ(std::stod(rows[k][0]), due[k / names.size()]) << "row " << k;
    EXPECT_EQ(rows[k][1], names[k % names.size()]) << "row " << k;
    for (int c = 2; c <= 7; ++c) EXPECT_TRUE(std::isfinite(std::stod(rows[k][c])));
    // The filter's sds: positive, and never above the widest prior (a
    // reset's, reset_scale_sd and reset_yaw_sd).
    const SelfCalibrationOptions prior;
    for (int c = 8; c <= 10; ++c) {
      const double sd = std::stod(rows[k][static_cast<std::size_t>(c)]);
      EXPECT_GT(sd, 0.0) << "row " << k << " column " << c;
      EXPECT_LE(sd, (c == 10 ? prior.reset_yaw_sd : prior.reset_scale_sd) * (1 + 1e-9))
          << "row " << k << " column " << c;
    }
  }
  // About once a second: 17 s of log, 18 or 19 sample times.
  EXPECT_GE(due.size(), 18u);
  EXPECT_LE(due.size(), 19u);

  const fs::path replayed = dir / "odometry-cal.csv";
  const auto odo =
      test::run_moa("odometry --quiet --config " + log + "/robot.yaml --log " + log + " --out " +
                    (dir / "o.csv").string() + " --self-calibration " + replayed.string());
  ASSERT_EQ(odo.exit_code, 0) << odo.err;
  EXPECT_EQ(test::read_text(cal), test::read_text(replayed));
}

std::string read_error(const std::string& text) {
  const fs::path file = test::scratch_dir("self-calibration-csv") / "cal.csv";
  std::ofstream(file) << text;
  try {
    io::read_self_calibration_csv(file);
  } catch (const io::Error& e) {
    const std::string what = e.what();
    const auto at = what.find("cal.csv");
    return at == std::string::npos ? what : what.substr(at);
  }
  return "(no error)";
}

TEST(SelfCalibrationCsv, ReadsWhatItWritesAndNamesTheLineOfBadRows) {
  const std::string header = "t,sensor,scale_x,scale_y,yaw_offset\n";
  EXPECT_EQ(read_error(header + "0.5,m1,1.01,0.99,0.002\n1.5,m1,1,1,0\n"), "(no error)");
  EXPECT_EQ(read_error("t,sensor,scale_x,yaw_offset\n0,m1,1,0\n"),
            "cal.csv:1: missing column 'scale_y'");
  EXPECT_EQ(read_error(header + "0,m1,1,x,0\n"),
            "cal.csv:2: column 'scale_y': 'x' is not a number");
  EXPECT_EQ(read_error(header + "0,m1,0,1,0\n"), "cal.csv:2: column 'scale_x': must be > 0");
  EXPECT_EQ(read_error(header + "0,m1,1,-1,0\n"), "cal.csv:2: column 'scale_y': must be > 0");
  EXPECT_EQ(read_error(header + "0,,1,1,0\n"), "cal.csv:2: column 'sensor': empty sensor name");
  EXPECT_THAT(read_error(header + "2,m1,1,1,0\n1,m1,1,1,0\n"), HasSubstr("cal.csv:3"));

  const fs::path file = test::scratch_dir("self-calibration-csv") / "ok.csv";
  std::ofstream(file) << header << "0.25,m2,0.95,0.9,-0.01\n";
  const auto rows = io::read_self_calibration_csv(file);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].t, 0.25);
  EXPECT_EQ(rows[0].sensor, "m2");
  EXPECT_EQ(rows[0].estimate.scale_x, 0.95);
  EXPECT_EQ(rows[0].estimate.scale_y, 0.9);
  EXPECT_EQ(rows[0].estimate.yaw_offset, -0.01);
  EXPECT_EQ(rows[0].filter.scale_x, 0.95);  // no filter columns: the filter's are the applied
  EXPECT_EQ(rows[0].filter.yaw_offset, -0.01);

  // With the filter's columns: read apart; one without the others is refused.
  const std::string both =
      "t,sensor,scale_x,scale_y,yaw_offset,filter_scale_x,filter_scale_y,"
      "filter_yaw_offset\n";
  std::ofstream(file) << both << "0.25,m2,1,1,0,1.004,0.997,0.001\n";
  const auto filtered = io::read_self_calibration_csv(file);
  ASSERT_EQ(filtered.size(), 1u);
  EXPECT_EQ(filtered[0].estimate.scale_x, 1.0);
  EXPECT_EQ(filtered[0].filter.scale_x, 1.004);
  EXPECT_EQ(filtered[0].filter.scale_y, 0.997);
  EXPECT_EQ(filtered[0].filter.yaw_offset, 0.001);
  EXPECT_EQ(read_error(both + "0,m1,1,1,0,0,1,0\n"),
            "cal.csv:2: column 'filter_scale_x': must be > 0");
  EXPECT_THAT(read_error(header.substr(0, header.size() - 1) + ",filter_scale_x\n0,m1,1,1,0,1\n"),
              HasSubstr("come together"));
}

}  // namespace
}  // namespace moa
