// The run summary (runs/run_summary.hpp) against an independent count of the
// odometry.csv the same run wrote: epochs by its `source` column, sensor-epochs
// by its `used` and `excluded` columns; and the verdict's rule.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "moa/formats/config.hpp"
#include "moa/runs/odometry_run.hpp"
#include "moa/runs/run_summary.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa::io {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> split(const std::string& text, char separator) {
  std::vector<std::string> out;
  std::string field;
  std::istringstream in(text);
  while (std::getline(in, field, separator)) out.push_back(field);
  return out;
}

// Counts read back from odometry.csv by its header's column names.
struct CsvCounts {
  std::size_t rows = 0;
  std::map<std::string, std::size_t> sources;  // by `source`
  std::map<std::string, std::size_t> sensors;  // "used", else the reason in `excluded`
};

CsvCounts count_csv(const fs::path& file) {
  std::ifstream in(file);
  std::string line;
  std::getline(in, line);
  while (!line.empty() && line[0] == '#') std::getline(in, line);
  const auto header = split(line, ',');
  std::map<std::string, std::size_t> column;
  for (std::size_t i = 0; i < header.size(); ++i) column[header[i]] = i;
  CsvCounts c;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    auto fields = split(line, ',');
    fields.resize(header.size());
    ++c.rows;
    ++c.sources[fields[column.at("source")]];
    for (const auto& name : split(fields[column.at("used")], '+')) {
      if (!name.empty()) ++c.sensors["used"];
    }
    for (const auto& entry : split(fields[column.at("excluded")], ';')) {
      if (entry.empty()) continue;
      // name:reason[/flag...]
      const std::string reason = entry.substr(entry.rfind(':') + 1);
      ++c.sensors[reason.substr(0, reason.find('/'))];
    }
  }
  return c;
}

TEST(RunSummary, CountsAreThoseOfOdometryCsv) {
  // A simulated run with faults: sensors excluded for several reasons.
  const fs::path dir = test::scratch_dir("run_summary");
  const auto sim = test::run_moa("simulate --scenario sekimori-b --seed 3 --out " + dir.string());
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  const std::string config_path = (dir / "robot.yaml").string();
  const RobotConfig config = read_config(config_path);
  for (const char* estimator : {"consensus", "sekimori"}) {
    const OdometryOptions options =
        resolve_odometry_options({}, estimator, {}, false, config, config_path);
    const fs::path out = dir / (std::string(estimator) + ".csv");
    const OdometryRun run = write_odometry(config, config_path, resolve_log(dir), options, out);
    const RunSummary& s = run.summary;
    const CsvCounts csv = count_csv(out);
    EXPECT_EQ(s.epochs, csv.rows) << estimator;
    EXPECT_EQ(s.epochs, run.steps) << estimator;
    std::size_t by_source = 0;
    for (std::size_t i = 0; i < kSourceCount; ++i) {
      const std::string name = to_name(static_cast<Source>(i));
      const auto it = csv.sources.find(name);
      EXPECT_EQ(s.epochs_by_source[i], it == csv.sources.end() ? 0u : it->second)
          << estimator << " " << name;
      by_source += s.epochs_by_source[i];
    }
    EXPECT_EQ(by_source, s.epochs);
    std::size_t by_reason = 0, excluded = 0;
    for (std::size_t i = 0; i < kExclusionCount; ++i) {
      const std::string name = to_name(static_cast<Exclusion>(i));
      const auto it = csv.sensors.find(name);
      EXPECT_EQ(s.sensor_epochs[i], it == csv.sensors.end() ? 0u : it->second)
          << estimator << " " << name;
      by_reason += s.sensor_epochs[i];
      if (i != 0) excluded += s.sensor_epochs[i];
    }
    // Every configured sensor, every epoch: used or excluded for one reason.
    EXPECT_EQ(by_reason, s.epochs * static_cast<std::size_t>(config.array.size()));
    EXPECT_GT(excluded, 0u) << estimator << ": the scenario's faults excluded no sensor";
  }
  fs::remove_all(dir);
}

TEST(RunSummary, UsableUnlessNoEpochOrMoreThanOnePercentHeld) {
  RunSummary s;
  EXPECT_FALSE(s.usable());
  EXPECT_EQ(s.verdict(), "not usable: no epoch was written");
  s.epochs = 200;
  s.epochs_by_source = {196, 2, 2};  // 1 % held: the bound, inclusive
  EXPECT_TRUE(s.usable());
  s.epochs_by_source = {195, 2, 3};
  EXPECT_FALSE(s.usable());
  EXPECT_EQ(s.verdict().rfind("not usable: 3 of 200 epochs (1.5 %) held", 0), 0u) << s.verdict();
}

TEST(RunSummary, MoaOdometryPrintsItsSummary) {
  const fs::path dir = test::scratch_dir("run_summary_cli");
  ASSERT_EQ(
      test::run_moa("simulate --scenario sekimori-b --seed 3 --out " + dir.string()).exit_code, 0);
  const fs::path out = dir / "odometry.csv";
  const auto r = test::run_moa("odometry --config " + (dir / "robot.yaml").string() + " --log " +
                               dir.string() + " --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const CsvCounts csv = count_csv(out);
  EXPECT_NE(r.out.find("epochs: " + std::to_string(csv.rows) + " (" +
                       std::to_string(csv.sources.at("mice")) + " mice"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("\nusable: "), std::string::npos) << r.out;
  fs::remove_all(dir);
}

// The report counts odometry.csv into the same RunSummary: its page shows
// the verdict `moa odometry` printed, word for word.
TEST(RunSummary, TheReportShowsTheVerdictMoaOdometryPrinted) {
  const fs::path dir = test::scratch_dir("run_summary_report");
  ASSERT_EQ(
      test::run_moa("simulate --scenario faults-bump --seed 2 --out " + dir.string()).exit_code, 0);
  const fs::path out = dir / "odometry.csv", page = dir / "report.html";
  const auto r = test::run_moa("odometry --config " + (dir / "robot.yaml").string() + " --log " +
                               dir.string() + " --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // The verdict is the summary's last line ("usable: ..." or "not usable: ...").
  const std::size_t at = r.out.find("usable: ");
  ASSERT_NE(at, std::string::npos) << r.out;
  const std::size_t start = r.out.rfind('\n', at) + 1;
  const std::string verdict = r.out.substr(start, r.out.find('\n', at) - start);
  const auto page_run =
      test::run_moa("report --config " + (dir / "robot.yaml").string() + " --log " + dir.string() +
                    " --odometry " + out.string() + " --out " + page.string());
  ASSERT_EQ(page_run.exit_code, 0) << page_run.err;
  EXPECT_NE(test::read_text(page).find(verdict), std::string::npos) << verdict;
  fs::remove_all(dir);
}

TEST(RunSummary, MoaLivePrintsItsSummaryAtTheEnd) {
  const fs::path dir = test::scratch_dir("run_summary_live");
  ASSERT_EQ(
      test::run_moa("simulate --scenario sekimori-b --seed 3 --out " + dir.string()).exit_code, 0);
  const fs::path out = dir / "live.csv";
  const auto r = test::run_moa("live --config " + (dir / "robot.yaml").string() + " --replay " +
                               dir.string() + " --speed 1000 --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const CsvCounts csv = count_csv(out);
  EXPECT_NE(
      r.out.find("epochs: " + std::to_string(csv.rows) + " (" +
                 std::to_string(csv.sources.count("mice") ? csv.sources.at("mice") : 0) + " mice"),
      std::string::npos)
      << r.out;
  // Live reads no wheels: epochs without a trusted sensor are held.
  const std::size_t held = csv.sources.count("hold") ? csv.sources.at("hold") : 0;
  const bool usable = static_cast<double>(held) <= 0.01 * static_cast<double>(csv.rows);
  EXPECT_NE(r.out.find(usable ? "\nusable: " : "\nnot usable: " + std::to_string(held) + " of "),
            std::string::npos)
      << r.out;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace moa::io
