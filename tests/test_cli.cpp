// The moa command end to end: what users and scripts rely on (docs/formats/cli.md).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "moa/analysis/evaluate.hpp"
#include "moa/formats/log.hpp"
#include "support/json_value.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

TEST(Cli, HelpListsSubcommands) {
  const auto r = test::run_moa("--help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_THAT(r.out, HasSubstr("odometry"));
  EXPECT_THAT(r.out, HasSubstr("evaluate"));
  EXPECT_THAT(r.out, HasSubstr("version"));
  EXPECT_EQ(test::run_moa("odometry --help").exit_code, 0);
}

TEST(Cli, VersionPrintsProjectVersion) {
  const auto r = test::run_moa("version");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_THAT(r.out, HasSubstr("moa 0."));
}

TEST(Cli, OdometryTracksNoiseFreeLogWithinMillimetre) {
  // 20 s of mixed motion, sensors with yaw, per-axis scale, one mirrored,
  // 100 Hz rows of integer counts. Bound: counts are exact to half a count
  // (<= 32 um at 400 cpi), so the pose error stays well under 1 mm / 2 mrad.
  const auto dir = test::scratch_dir("odometry");
  const SensorArray array = test::skewed_array();
  const auto log = test::synthesise(array, test::mixed_motion, 20.0, 0.01);
  test::write_log(log, array, {"a", "b", "c", "d"}, dir);
  const auto r =
      test::run_moa("odometry --config " + (dir / "robot.yaml").string() + " --log " +
                    dir.string() + " --estimator ls --out " + (dir / "odom.csv").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("odom.csv"));

  TrajectoryErrorAccumulator acc(log.truth);
  io::TruthReader odometry(dir / "odom.csv");
  while (const auto row = odometry.next()) acc.add(row->t, row->pose);
  const TrajectoryError e = acc.result();
  EXPECT_EQ(e.samples, 2000u);
  EXPECT_EQ(e.outside, 0u);
  EXPECT_LT(e.max_translation, 1e-3);
  EXPECT_LT(e.max_heading, 2e-3);

  const auto ev = test::run_moa("evaluate --json --truth " + (dir / "truth.csv").string() +
                                " --odometry " + (dir / "odom.csv").string());
  ASSERT_EQ(ev.exit_code, 0) << ev.err;
  EXPECT_THAT(ev.out, HasSubstr("\"max_translation_m\""));
  fs::remove_all(dir);
}

TEST(Cli, BadInputFailsWithOneLineAndNoOutputFile) {
  const auto dir = test::scratch_dir("badinput");
  const SensorArray array = test::skewed_array();
  const auto log = test::synthesise(array, test::mixed_motion, 1.0, 0.01);
  test::write_log(log, array, {"a", "b", "c", "d"}, dir);
  {
    std::ofstream mice(dir / "mice.csv", std::ios::app);
    mice << "1.5,zz,1,1\n";
  }
  const auto out = dir / "odom.csv";
  const auto r = test::run_moa("odometry --config " + (dir / "robot.yaml").string() + " --log " +
                               dir.string() + " --out " + out.string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, HasSubstr("mice.csv:"));
  EXPECT_THAT(r.err, HasSubstr("zz"));
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_FALSE(fs::exists(out));
  // Nothing else was left beside it either (no temporary files).
  for (const auto& entry : fs::directory_iterator(dir)) {
    EXPECT_THAT(entry.path().filename().string(), ::testing::Not(HasSubstr("odom")));
  }
  fs::remove_all(dir);
}

TEST(Cli, SilenceLongerThanMaxGapIsAnErrorAndWritesNothing) {
  // One second of motion, then a last row 60 s later: 60 s of still epochs
  // are fine under --max-gap 100 and an error under --max-gap 10 (a gap is
  // written epoch by epoch, so recordings glued from different days would
  // write millions of rows).
  const auto dir = test::scratch_dir("gap");
  const SensorArray array = test::skewed_array();
  const auto log = test::synthesise(array, test::mixed_motion, 1.0, 0.01);
  test::write_log(log, array, {"a", "b", "c", "d"}, dir);
  {
    std::ofstream mice(dir / "mice.csv", std::ios::app);
    mice << "61,a,0,0\n";
  }
  const std::string common = "odometry --config " + (dir / "robot.yaml").string() + " --log " +
                             dir.string() + " --out " + (dir / "odom.csv").string();
  const auto refused = test::run_moa(common + " --max-gap 10");
  EXPECT_NE(refused.exit_code, 0);
  EXPECT_THAT(refused.err, HasSubstr("mice.csv:"));
  EXPECT_THAT(refused.err, HasSubstr("--max-gap"));
  EXPECT_FALSE(fs::exists(dir / "odom.csv"));
  const auto accepted = test::run_moa(common + " --max-gap 100");
  ASSERT_EQ(accepted.exit_code, 0) << accepted.err;
  std::ifstream odometry(dir / "odom.csv");
  const auto lines =
      std::count(std::istreambuf_iterator<char>(odometry), std::istreambuf_iterator<char>(), '\n');
  EXPECT_EQ(lines, 1 + 6100);  // header, one row per 10 ms epoch up to t = 61 s
  fs::remove_all(dir);
}

TEST(Cli, EpochRateAndRowIntervalAreBounded) {
  // Epochs are written one per period and the synchroniser keeps a slot per
  // period of the longest row interval: absurd values would write or
  // allocate without bound, so they are refused up front, naming the option.
  const std::string common = "odometry --config " MOA_SOURCE_DIR
                             "/examples/logs/mixed-motion/robot.yaml "
                             "--log " MOA_SOURCE_DIR "/examples/logs/mixed-motion --out never.csv";
  for (const std::string bad : {"--rate 1e9", "--rate 0", "--max-row-interval 1e9"}) {
    const auto r = test::run_moa(common + " " + bad);
    EXPECT_NE(r.exit_code, 0) << bad;
    EXPECT_THAT(r.err, HasSubstr(bad.substr(0, bad.find(' ')))) << bad;
    EXPECT_FALSE(fs::exists("never.csv"));
  }
}

TEST(Cli, EveryEstimatorTracksNoiseFreeLog) {
  // On fault-free data all three estimators use every sensor and agree with truth.
  const auto dir = test::scratch_dir("estimators");
  const SensorArray array = test::skewed_array();
  const auto log = test::synthesise(array, test::mixed_motion, 5.0, 0.01);
  test::write_log(log, array, {"a", "b", "c", "d"}, dir);
  for (const std::string name : {"ls", "sekimori", "consensus"}) {
    const auto out = dir / (name + ".csv");
    const auto r = test::run_moa("odometry --config " + (dir / "robot.yaml").string() + " --log " +
                                 dir.string() + " --estimator " + name + " --out " + out.string());
    ASSERT_EQ(r.exit_code, 0) << r.err;
    TrajectoryErrorAccumulator acc(log.truth);
    io::TruthReader odometry(out);
    while (const auto row = odometry.next()) acc.add(row->t, row->pose);
    EXPECT_LT(acc.result().max_translation, 1e-3) << name;
    EXPECT_LT(acc.result().max_heading, 2e-3) << name;
  }
  const auto bad = test::run_moa("odometry --config " + (dir / "robot.yaml").string() + " --log " +
                                 dir.string() + " --estimator magic --out x.csv");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_THAT(bad.err, HasSubstr("magic"));
  fs::remove_all(dir);
}

/// How many rows of an odometry.csv have each value of the `source` column.
std::map<std::string, int> sources(const fs::path& odometry) {
  std::ifstream in(odometry);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header;
  std::stringstream h(line);
  for (std::string field; std::getline(h, field, ',');) header.push_back(field);
  const auto column = std::find(header.begin(), header.end(), "source") - header.begin();
  std::map<std::string, int> count;
  while (std::getline(in, line)) {
    std::stringstream row(line);
    std::string field;
    for (long k = 0; k <= column; ++k) std::getline(row, field, ',');
    ++count[field];
  }
  return count;
}

TEST(Cli, VotingThresholdsComeFromTheCommandLine) {
  // Eq. (7): a sensor is reliable with r_i >= r_th agreeing pairs, and each
  // of N = 4 sensors has only N - 1 = 3 pairs: r_th = 4 trusts no sensor, so
  // every epoch falls back (no wheels: the held twist); the default r_th = 2
  // trusts all on fault-free data.
  const auto dir = test::scratch_dir("thresholds");
  const SensorArray array = test::skewed_array();
  const auto log = test::synthesise(array, test::mixed_motion, 2.0, 0.01);
  test::write_log(log, array, {"a", "b", "c", "d"}, dir);
  const std::string common = "odometry --config " + (dir / "robot.yaml").string() + " --log " +
                             dir.string() + " --estimator sekimori --out ";
  ASSERT_EQ(test::run_moa(common + (dir / "default.csv").string()).exit_code, 0);
  const auto strict = test::run_moa(common + (dir / "strict.csv").string() + " --r-th 4");
  ASSERT_EQ(strict.exit_code, 0) << strict.err;
  EXPECT_EQ(sources(dir / "default.csv"), (std::map<std::string, int>{{"mice", 200}}));
  EXPECT_EQ(sources(dir / "strict.csv"), (std::map<std::string, int>{{"hold", 200}}));
  // Out of range values are refused, naming the option.
  for (const std::string bad : {" --r-th 0", " --e-th -1", " --alpha 0.9"}) {
    const auto r = test::run_moa(common + (dir / "bad.csv").string() + bad);
    EXPECT_NE(r.exit_code, 0) << bad;
    EXPECT_THAT(r.err, HasSubstr(bad.substr(1, bad.find(' ', 1) - 1))) << bad;
    EXPECT_FALSE(fs::exists(dir / "bad.csv")) << bad;
  }
  fs::remove_all(dir);
}

TEST(Cli, BenchJsonHasTheContractKeys) {
  // Keys only: speed figures are measured by `moa bench` itself, not asserted here.
  const auto r = test::run_moa("bench --json --batches 3 --updates 20");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* key :
       {"\"ls_ns_per_update\"", "\"naive_ls_ns_per_update\"", "\"sekimori_ns_per_update\"",
        "\"naive_sekimori_ns_per_update\"", "\"consensus_ns_per_update\"",
        "\"consensus_over_sekimori\"", "\"machine\"", "\"compiler\""}) {
    EXPECT_THAT(r.out, HasSubstr(key));
  }
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1);
}

TEST(Cli, BenchReplayMeasuresBothPassesAndLeavesNoLog) {
  // Keys and cleanup only: the times are the benchmark's to report.
  const auto dir = test::scratch_dir("bench_replay");
  const auto r =
      test::run_moa("bench --replay --json --duration 2 --repeats 1 --dir " + dir.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* key : {"\"parse_only_s\"", "\"replay_s\"", "\"real_time_factor\"",
                          "\"replay_over_parse\"", "\"mice_rows\": 8004", "\"epochs\": 2000"}) {
    EXPECT_THAT(r.out, HasSubstr(key));
  }
  EXPECT_TRUE(fs::is_empty(dir));
  // The generated log has mice.csv only: an estimator that needs more is refused by name.
  const auto wheels =
      test::run_moa("bench --replay --estimator wheels --duration 2 --dir " + dir.string());
  EXPECT_EQ(wheels.exit_code, 1);
  EXPECT_EQ(wheels.err,
            "moa bench: error: --estimator: 'wheels' is not ls, sekimori or consensus (the log "
            "has no wheels and no faults)\n");
  EXPECT_TRUE(fs::is_empty(dir));
}

TEST(Cli, BenchLiveMeasuresEveryStepAtBothRatesAndLeavesNoLog) {
  // Counts, order and cleanup only: the latencies are the benchmark's to report.
  const auto dir = test::scratch_dir("bench_live");
  const auto r = test::run_moa("bench --live --json --duration 1 --dir " + dir.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const test::JsonValue j = test::JsonValue::parse(r.out);
  for (const char* key : {"latency", "latency_reader_stalled"}) {
    const auto& rates = j[key].array();
    ASSERT_EQ(rates.size(), 2u) << key;
    for (std::size_t k = 0; k < 2; ++k) {
      const double hz = k == 0 ? 100.0 : 1000.0;
      const auto& e = rates[k];
      EXPECT_EQ(e["rate_hz"].number(), hz);
      // A step per epoch of the 1 s log (and the one the end of the stream cuts).
      EXPECT_NEAR(e["steps"].number(), hz, 1.0) << key;
      EXPECT_LE(e["p50_s"].number(), e["p99_s"].number());
      EXPECT_LE(e["p99_s"].number(), e["max_s"].number());
      EXPECT_GT(e["p50_s"].number(), 0.0);
      EXPECT_EQ(e["lines_dropped"].number(), 0.0);
      // A reading reader got every line; a stalled one none.
      EXPECT_EQ(e["lines_received"].number(),
                std::string(key) == "latency" ? e["steps"].number() : 0.0);
    }
  }
  EXPECT_TRUE(fs::is_empty(dir));
}

TEST(Cli, RankDeficientConfigIsRefused) {
  const auto dir = test::scratch_dir("rank");
  SensorMount m;
  m.position = {0.1, 0.0};
  const SensorArray array({m, m});
  test::write_log(test::synthesise(array, test::mixed_motion, 0.1, 0.01), array, {"a", "b"}, dir);
  const auto r = test::run_moa("odometry --config " + (dir / "robot.yaml").string() + " --log " +
                               dir.string() + " --out " + (dir / "o.csv").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, HasSubstr("robot.yaml"));
  EXPECT_THAT(r.err, HasSubstr("rank-deficient"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace moa
