// The one run loop (runs/run_loop.hpp) that `moa odometry` and `moa live`
// share: a live source over a log gives the steps of the log's replay; rows
// reach the pipeline in the source's order; a refused row is named by its
// source's place and time; a silent sensor is refused for least squares and a
// warning for consensus. And the library's option errors, worded without the
// CLI's flags (runs/option_error.hpp).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <variant>
#include <vector>

#include "moa/formats/config.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/log.hpp"
#include "moa/runs/live_source.hpp"
#include "moa/runs/odometry_run.hpp"
#include "moa/runs/option_error.hpp"
#include "moa/runs/run_loop.hpp"
#include "support/error_of.hpp"
#include "support/synth.hpp"

namespace moa::io {
namespace {

namespace fs = std::filesystem;
using test::error_of;
using ::testing::HasSubstr;

const std::vector<std::string> kNames{"a", "b", "c", "d"};

RobotConfig config_of(const SensorArray& array) {
  RobotConfig config;
  config.array = array;
  config.names = kNames;
  return config;
}

/// Rows handed out as they are, each named "rows:INDEX" (1-based).
class VectorSource final : public RunSource {
 public:
  VectorSource(double t0, std::vector<InputRow> rows) : t0_(t0), rows_(std::move(rows)) {}
  double start_time() override { return t0_; }
  const InputRow* next() override { return at_ < rows_.size() ? &rows_[at_++] : nullptr; }
  std::string where() const override { return "rows:" + std::to_string(at_); }

 private:
  double t0_;
  std::vector<InputRow> rows_;
  std::size_t at_ = 0;
};

struct Steps {
  std::vector<double> t;
  std::vector<Pose2> pose;
};

TEST(RunLoop, ALiveSourceOverALogGivesTheStepsOfTheLogsReplay) {
  const SensorArray array = test::skewed_array();
  const fs::path dir = test::scratch_dir("run_loop_live");
  test::write_log(test::synthesise(array, test::mixed_motion, 5.0, 0.002), array, kNames, dir);
  const RobotConfig config = read_config(dir / "robot.yaml");
  OdometryOptions options;
  options.estimator = EstimatorKind::kConsensus;
  options.rate = 200.0;

  Steps replayed, live;
  const auto collect = [](Steps& into) {
    return [&into](const OdometryStep& step) {
      into.t.push_back(step.t());
      into.pose.push_back(step.pose);
    };
  };
  const OdometryRun a =
      run_odometry(config, "robot.yaml", resolve_log(dir), options, collect(replayed));
  // mice.csv as a live source: a zero row per sensor at t0 first, then the rows.
  MiceReader mice(dir / "mice.csv", config);
  LiveRunSource source(mice, config.array.size(), "live");
  RunCallbacks callbacks;
  callbacks.on_step = collect(live);
  const OdometryRun b = run_loop(config, "robot.yaml", options, source, "live", callbacks);

  EXPECT_EQ(b.rows, a.rows + 4);  // the zero rows
  EXPECT_EQ(a.steps, replayed.t.size());
  ASSERT_EQ(live.t.size(), replayed.t.size());
  ASSERT_GT(live.t.size(), 900u);  // 5 s at 200 Hz
  for (std::size_t k = 0; k < live.t.size(); ++k) {
    ASSERT_EQ(live.t[k], replayed.t[k]) << k;
    ASSERT_EQ(live.pose[k].t, replayed.pose[k].t) << k;
    ASSERT_EQ(live.pose[k].theta, replayed.pose[k].theta) << k;
  }
}

TEST(RunLoop, RowsReachThePipelineInTheSourcesOrderAndAreCountedByKind) {
  const RobotConfig config = config_of(test::skewed_array());
  std::vector<InputRow> rows;
  for (int k = 0; k <= 100; ++k) {
    const double t = 0.01 * k;
    if (k % 10 == 5) rows.emplace_back(WheelRow{t, Twist2{{0.1, 0.0}, 0.0}});
    if (k == 50) rows.emplace_back(CameraFix{t, {0.05, 0.0}, std::nullopt, std::nullopt});
    for (int i = 0; i < 4; ++i) {
      SensorRow row;
      row.t = t;
      row.sensor = i;
      if (k > 0) row.counts = config.array[i].counts({{0.1, 0.0}, 0.0}, 0.01);
      rows.emplace_back(row);
    }
  }
  VectorSource source(0.0, rows);
  std::vector<double> seen;
  RunCallbacks callbacks;
  callbacks.on_row = [&](const InputRow& row) { seen.push_back(row_time(row)); };
  OdometryOptions options;
  options.estimator = EstimatorKind::kLs;
  options.rate = 100.0;
  options.fuse_camera = true;
  const OdometryRun run = run_loop(config, "robot.yaml", options, source, "rows", callbacks);
  ASSERT_EQ(seen.size(), rows.size());
  for (std::size_t k = 0; k < rows.size(); ++k) EXPECT_EQ(seen[k], row_time(rows[k])) << k;
  EXPECT_EQ(run.rows, 404u);
  EXPECT_EQ(run.wheel_rows, 10u);
  EXPECT_EQ(run.fix_rows, 1u);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_EQ(run.rows_per_sensor[i], 101u) << i;
  EXPECT_EQ(run.t0, 0.0);
  EXPECT_EQ(run.t_end, 1.0);
  EXPECT_EQ(run.steps, 100u);  // 1 s at 100 Hz
}

// A burst of 300 wheel rows before one mice row is more than the
// pipeline's ring keeps ahead of the mice (256 rows, the first only opening
// the record): a file's run ends saying so; a live run's (on_stream_full
// set) hands the rows beyond to it, unrecorded, and goes on to its end.
TEST(RunLoop, ABurstOfStreamRowsIsHandedToOnStreamFullWhenSetAndEndsTheRunElse) {
  const RobotConfig config = config_of(test::skewed_array());
  std::vector<InputRow> rows;
  for (int i = 0; i < 4; ++i) rows.emplace_back(SensorRow{0.0, i, {0, 0}, std::nullopt, 0, 0});
  for (int k = 1; k <= 300; ++k) rows.emplace_back(WheelRow{1e-6 * k, Twist2{{0.1, 0.0}, 0.0}});
  for (int k = 1; k <= 10; ++k) {
    for (int i = 0; i < 4; ++i)
      rows.emplace_back(SensorRow{0.01 * k, i, {0, 0}, std::nullopt, 0, 0});
  }
  OdometryOptions options;
  options.estimator = EstimatorKind::kSekimori;
  options.rate = 100.0;
  {
    VectorSource source(0.0, rows);
    EXPECT_THROW(run_loop(config, "robot.yaml", options, source, "rows", {}), Error);
  }
  VectorSource source(0.0, rows);
  std::size_t recorded = 0, full = 0;
  RunCallbacks callbacks;
  callbacks.on_row = [&](const InputRow& row) {
    recorded += std::holds_alternative<WheelRow>(row);
  };
  callbacks.on_stream_full = [&](const InputRow& row, const std::string& why) {
    EXPECT_TRUE(std::holds_alternative<WheelRow>(row));
    EXPECT_NE(why.find("wheel rows fed too far ahead of the mice rows"), std::string::npos) << why;
    ++full;
  };
  const OdometryRun run = run_loop(config, "robot.yaml", options, source, "rows", callbacks);
  EXPECT_EQ(run.wheel_rows, 257u);
  EXPECT_EQ(recorded, 257u);
  EXPECT_EQ(full, 43u);
  EXPECT_EQ(run.rows, 44u);
  EXPECT_EQ(run.steps, 10u);
}

TEST(RunLoop, ARefusedRowIsNamedByItsSourcesPlaceAndTime) {
  const RobotConfig config = config_of(test::skewed_array());
  std::vector<InputRow> rows;
  for (int i = 0; i < 4; ++i) rows.emplace_back(SensorRow{0.5, i, {0, 0}, std::nullopt, 0, 0});
  rows.emplace_back(SensorRow{0.25, 2, {1, 1}, std::nullopt, 0, 0});  // row 5 goes back in time
  VectorSource source(0.0, rows);
  OdometryOptions options;
  EXPECT_EQ(error_of([&] { run_loop(config, "robot.yaml", options, source, "rows", {}); }),
            std::string("rows:5: row at t = 0.25 s: ") + describe(RowError::kTimeBackwards));
}

TEST(RunLoop, ASilentSensorIsRefusedForLeastSquaresAndAWarningForConsensus) {
  const RobotConfig config = config_of(test::skewed_array());
  std::vector<InputRow> rows;
  for (int k = 0; k <= 10; ++k) {
    for (int i = 0; i < 3; ++i)
      rows.emplace_back(SensorRow{0.01 * k, i, {0, 0}, std::nullopt, 0, 0});
  }
  OdometryOptions options;
  options.estimator = EstimatorKind::kLs;
  VectorSource ls_rows(0.0, rows);
  EXPECT_EQ(error_of([&] { run_loop(config, "robot.yaml", options, ls_rows, "the rows", {}); }),
            "the rows: sensor 'd' of robot.yaml never reports: ls would take it as still; leave it "
            "out of the selected sensors or use a robust estimator (consensus, sekimori)");

  options.estimator = EstimatorKind::kConsensus;
  VectorSource consensus_rows(0.0, rows);
  std::vector<std::string> said;
  RunCallbacks callbacks;
  callbacks.warn = [&](const std::string& w) { said.push_back(w); };
  const OdometryRun run =
      run_loop(config, "robot.yaml", options, consensus_rows, "the rows", callbacks);
  const std::string warning =
      "the rows: sensor 'd' of robot.yaml never reports: the consensus estimator saw it as a "
      "still sensor";
  EXPECT_EQ(said, std::vector<std::string>{warning});
  EXPECT_EQ(run.summary.warnings, std::vector<std::string>{warning});

  // Left out of the selection, it is not asked for.
  options.estimator = EstimatorKind::kLs;
  options.sensors = 0b0111;
  VectorSource selected_rows(0.0, rows);
  EXPECT_TRUE(run_loop(config, "robot.yaml", options, selected_rows, "the rows", {})
                  .summary.warnings.empty());
}

TEST(OptionError, NamesTheOptionsAsTheLibraryDoesAndAsTheCallerRendersThem) {
  const OptionError e("{estimator} wheels and {no_wheels} exclude each other");
  EXPECT_STREQ(e.what(), "estimator wheels and no_wheels exclude each other");
  EXPECT_EQ(e.render([](std::string_view name) { return "--" + std::string(name); }),
            "--estimator wheels and --no_wheels exclude each other");
  // A value with braces stays as it is.
  const OptionError v("{sensors}: unknown sensor '" + OptionError::literal("a{b}") + "'");
  EXPECT_STREQ(v.what(), "sensors: unknown sensor 'a{b}'");
  EXPECT_EQ(v.render([](std::string_view) { return std::string("-s"); }),
            "-s: unknown sensor 'a{b}'");
}

TEST(OptionError, ResolvingOptionsNamesTheFieldNotAFlag) {
  const RobotConfig config = config_of(test::skewed_array());
  const auto message = [&](std::string_view estimator, std::vector<std::string> sensors,
                           bool no_wheels, bool wheel_gauge = false) {
    OdometryOptions o;
    o.self_calibration.enabled = wheel_gauge;
    if (wheel_gauge) o.self_calibration.gauge = SelfCalibrationGauge::kWheels;
    try {
      resolve_odometry_options(o, estimator, sensors, no_wheels, config, "robot.yaml");
    } catch (const OptionError& e) {
      return e.render([](std::string_view name) { return "<" + std::string(name) + ">"; });
    }
    return std::string("no error");
  };
  EXPECT_EQ(message("lsq", {}, false), "<estimator>: unknown estimator 'lsq'");
  EXPECT_EQ(message("wheels", {}, true), "<estimator> wheels and <no_wheels> exclude each other");
  EXPECT_EQ(message("consensus", {}, true, true),
            "<self_calibration.gauge> wheels and <no_wheels> exclude each other");
  EXPECT_EQ(message("ls", {"a", "z"}, false),
            "<sensors>: unknown sensor 'z' (robot.yaml has a, b, c, d)");
  EXPECT_EQ(message("ls", {"a", "b", "a"}, false), "<sensors>: sensor 'a' named twice");
  EXPECT_EQ(message("ls", {"a", "b", "c"}, false), "no error");
}

}  // namespace
}  // namespace moa::io
