// diagnostics.csv: the status record of every source, written and read back.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>

#include "moa/formats/config.hpp"
#include "moa/formats/diagnostics_csv.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/odometry_csv.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa::io {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

OdometryStep step_at(const ArraySample& sample) {
  OdometryStep step;
  step.sample = &sample;
  return step;
}

// `text` written to `file` is refused by the reader, with `error` in the message.
void expect_refused(const fs::path& file, const std::string& text, const std::string& error) {
  std::ofstream(file) << text;
  try {
    read_diagnostics_csv(file);
    ADD_FAILURE() << "no error for " << text;
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr(error)) << text;
  }
}

TEST(DiagnosticsCsv, EverySelectedSourceRoundTrips) {
  const fs::path file = test::scratch_dir("diagnostics") / "d.csv";
  ArraySample sample;
  sample.t = 0.25;
  sample.size = 3;
  OdometryStep step = step_at(sample);
  step.estimate.source = Source::kWheels;
  step.estimate.estimate.used = 0b001;
  step.estimate.excluded[1] = Exclusion::kCommonMode;
  step.estimate.excluded[2] = Exclusion::kUnselected;
  step.estimate.tests.sensor[0] = 0.125;
  step.estimate.tests.sensor[1] = 3.5;
  step.estimate.tests.wheels = 0.75;  // prior left NaN: not tested
  {
    DiagnosticsCsvWriter w(file, {"m1", "m2", "m3"}, 0b011);
    w.write(step);
    EXPECT_FALSE(fs::exists(file)) << "nothing appears before commit";
    w.commit();
  }
  const auto rows = read_diagnostics_csv(file);
  ASSERT_EQ(rows.size(), 4u);  // m1, m2 (m3 not selected), wheels, prior
  EXPECT_EQ(rows[0].source, "m1");
  EXPECT_DOUBLE_EQ(rows[0].test_ratio, 0.125);
  EXPECT_TRUE(rows[0].fused);
  EXPECT_EQ(rows[0].reason, "");
  EXPECT_EQ(rows[1].source, "m2");
  EXPECT_DOUBLE_EQ(rows[1].test_ratio, 3.5);
  EXPECT_FALSE(rows[1].fused);
  EXPECT_EQ(rows[1].reason, "common-mode");
  EXPECT_EQ(rows[2].source, "wheels");
  EXPECT_TRUE(rows[2].fused);
  EXPECT_DOUBLE_EQ(rows[2].test_ratio, 0.75);
  EXPECT_EQ(rows[3].source, "prior");
  EXPECT_TRUE(std::isnan(rows[3].test_ratio));
  EXPECT_FALSE(rows[3].fused);
  for (const auto& r : rows) {
    EXPECT_DOUBLE_EQ(r.t, 0.25);
    EXPECT_FALSE(r.bias.has_value()) << r.source << ": only imu rows carry the gyro's";
  }
}

// A file written before the gyro's columns (bias, scale) still reads; when
// present they come together, finite, the scale positive.
TEST(DiagnosticsCsv, GyroCalibrationColumnsAreOptionalAndChecked) {
  const fs::path dir = test::scratch_dir("diagnostics-gyro");
  const fs::path file = dir / "d.csv";
  std::ofstream(file) << "t,source,test_ratio,fused,reason\n0.1,imu,0.5,1,\n";
  auto rows = read_diagnostics_csv(file);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_FALSE(rows[0].bias.has_value());
  std::ofstream(file) << "t,source,test_ratio,fused,reason,bias,scale\n"
                         "0.1,prior,,0,,,\n0.1,imu,0.5,1,,-0.0125,1.0203\n";
  rows = read_diagnostics_csv(file);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_FALSE(rows[0].bias.has_value());
  ASSERT_TRUE(rows[1].bias.has_value());
  EXPECT_DOUBLE_EQ(*rows[1].bias, -0.0125);
  EXPECT_DOUBLE_EQ(*rows[1].scale, 1.0203);
  const struct {
    const char* row;
    const char* error;
  } bad[] = {
      {"0.1,imu,0.5,1,,0.01,\n", "bias and scale come together"},
      {"0.1,imu,0.5,1,,,1.02\n", "bias and scale come together"},
      {"0.1,imu,0.5,1,,nan,1.02\n", "d.csv:2"},
      {"0.1,imu,0.5,1,,0.01,0\n", "must be > 0"},
  };
  for (const auto& c : bad) {
    expect_refused(file, std::string("t,source,test_ratio,fused,reason,bias,scale\n") + c.row,
                   c.error);
  }
  fs::remove_all(dir);
}

TEST(DiagnosticsCsv, BadRowsAreRefusedWithFileAndLine) {
  const fs::path dir = test::scratch_dir("diagnostics-bad");
  const struct {
    const char* text;
    const char* error;
  } cases[] = {
      {"t,source,test_ratio,fused\n", "reason"},
      {"t,source,test_ratio,fused,reason\n0.1,m1,-1,1,\n", "d.csv:2"},
      {"t,source,test_ratio,fused,reason\n0.1,m1,1,2,\n", "must be 0 or 1"},
      {"t,source,test_ratio,fused,reason\n0.1,m1,nan,1,\n", "d.csv:2"},
      {"t,source,test_ratio,fused,reason\n0.2,m1,1,1,\n0.1,m1,1,1,\n", "d.csv:3"},
      {"t,source,test_ratio,fused,reason\n0.1,,1,1,\n", "empty source"},
  };
  for (const auto& c : cases) expect_refused(dir / "d.csv", c.text, c.error);
}

// `moa simulate --scenario SCENARIO --seed 101`, then `moa odometry
// --diagnostics` on it: what the tests below read (no rows on a failure).
struct Diagnosed {
  std::string config_path;
  RobotConfig config;
  std::vector<DiagnosticsRow> rows;
  fs::path out;  ///< odometry.csv
};
Diagnosed diagnosed(const std::string& scenario) {
  const fs::path dir = test::scratch_dir("diagnostics-" + scenario);
  const std::string log = (dir / "log").string();
  Diagnosed d;
  d.config_path = log + "/robot.yaml";
  d.out = dir / "o.csv";
  const fs::path diag = dir / "d.csv";
  const auto sim = test::run_moa("simulate --scenario " + scenario + " --seed 101 --out " + log);
  EXPECT_EQ(sim.exit_code, 0) << sim.err;
  if (sim.exit_code != 0) return d;
  const auto r = test::run_moa("odometry --config " + d.config_path + " --log " + log + " --out " +
                               d.out.string() + " --diagnostics " + diag.string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  if (r.exit_code != 0) return d;
  d.config = read_config(d.config_path);
  d.rows = read_diagnostics_csv(diag);
  return d;
}

// moa odometry --diagnostics on common-mode dropouts (faults-bump): the file
// agrees with odometry.csv epoch by epoch (a sensor fused exactly when
// used, the wheels fused exactly when the source is `wheels`), and every
// epoch reported `common-mode` has both references' statistics over their
// gates, as the rule says (docs/math.md), and the rule fires.
TEST(DiagnosticsCli, AgreesWithOdometryAndShowsTheCommonModeTest) {
  const Diagnosed run = diagnosed("faults-bump");
  ASSERT_FALSE(run.rows.empty());
  const RobotConfig& config = run.config;
  const auto& rows = run.rows;
  const std::size_t per_epoch = config.names.size() + 2;
  OdometryCsvReader odometry(run.out, config, run.config_path);
  std::size_t k = 0, common = 0;
  while (const auto o = odometry.next()) {
    ASSERT_LE(k + per_epoch, rows.size());
    bool any_common = false;
    for (std::size_t i = 0; i < config.names.size(); ++i) {
      const DiagnosticsRow& d = rows[k + i];
      EXPECT_DOUBLE_EQ(d.t, o->t);
      EXPECT_EQ(d.source, config.names[i]);
      EXPECT_EQ(d.fused, contains(o->used, static_cast<int>(i))) << "t " << o->t;
      // The reason as odometry.csv's `excluded` has it, noise flags too.
      if (contains(o->listed, static_cast<int>(i)) && !d.fused) {
        EXPECT_EQ(d.reason, describe_exclusion(o->excluded[i], o->noise_flags[i])) << "t " << o->t;
      }
      if (d.reason == "common-mode") any_common = true;
    }
    const DiagnosticsRow& wheels = rows[k + config.names.size()];
    const DiagnosticsRow& prior = rows[k + config.names.size() + 1];
    EXPECT_EQ(wheels.source, "wheels");
    EXPECT_EQ(prior.source, "prior");
    EXPECT_EQ(wheels.fused, o->source == Source::kWheels) << "t " << o->t;
    if (any_common) {
      ++common;
      EXPECT_GT(wheels.test_ratio, 1.0) << "t " << o->t;
      EXPECT_GT(prior.test_ratio, 1.0) << "t " << o->t;
    }
    k += per_epoch;
  }
  EXPECT_EQ(k, rows.size());
  // Three dropouts of 0.3 s at 100 Hz: at least a few epochs of each are
  // caught (the rest may be bridged as well, through the health monitor).
  EXPECT_GE(common, 3u);
}

// A sensor's reason is odometry.csv's `excluded` text, its noise flags
// included: faults-drift at speed (a) runs over the HDNS-2051's rating, so
// some exclusions carry `/over-speed`.
TEST(DiagnosticsCli, ASensorsReasonIsItsExcludedTextWithItsNoiseFlags) {
  const Diagnosed run = diagnosed("faults-drift");
  ASSERT_FALSE(run.rows.empty());
  const RobotConfig& config = run.config;
  const auto& rows = run.rows;
  OdometryCsvReader odometry(run.out, config, run.config_path);
  std::size_t k = 0, flagged = 0;
  while (const auto o = odometry.next()) {
    for (std::size_t i = 0; i < config.names.size(); ++i) {
      ASSERT_LT(k + i, rows.size());
      const DiagnosticsRow& d = rows[k + i];
      if (contains(o->used, static_cast<int>(i))) continue;
      const std::string excluded = describe_exclusion(o->excluded[i], o->noise_flags[i]);
      EXPECT_EQ(d.reason, excluded) << "t " << o->t;
      if (excluded.find('/') != std::string::npos) ++flagged;
    }
    k += config.names.size() + 2;
    while (k < rows.size() && rows[k].source == "imu") ++k;
  }
  EXPECT_GT(flagged, 0u);
}

TEST(DiagnosticsCli, RefusesAnOutputThatIsAnInput) {
  const fs::path dir = test::scratch_dir("diagnostics-careless");
  const std::string log = (dir / "log").string();
  ASSERT_EQ(test::run_moa("simulate --scenario sekimori-a --seed 101 --out " + log).exit_code, 0);
  const std::string odometry = "odometry --config " + log + "/robot.yaml --log " + log + " --out " +
                               (dir / "o.csv").string() + " --diagnostics ";
  for (const std::string& target : {log + "/mice.csv", (dir / "o.csv").string()}) {
    const auto r = test::run_moa(odometry + target);
    EXPECT_EQ(r.exit_code, 1) << target;
    EXPECT_THAT(r.err, HasSubstr("--diagnostics")) << r.err;
  }
  const auto dash = test::run_moa(odometry + "--quiet");
  EXPECT_EQ(dash.exit_code, 2) << dash.err;
}

}  // namespace
}  // namespace moa::io
