// `moa experiment gyro` (docs/experiments.md) on the test seeds 101-105,
// checked against what the test computes itself:
//  - the gyro alone: the test simulates gyro-compact with seed 101 (`moa
//    simulate`), integrates imu.csv itself, theta_j = theta_{j-1} + (g_j -
//    c) / k (t_j - t_{j-1}) from the truth's start heading, and compares
//    with truth.csv at t_j - latency: with robot.yaml's k, c it must give
//    the experiment's max and RMS error; with robot.true.yaml's scale and a
//    bias off the true one by db the final error is db T (T the run's
//    length: the heading error grows with the bias error), for two db;
//  - the bias measured at rest is the true one (robot.true.yaml) to 1 mrad/s;
//  - fused beats the array alone on the compact array: its RMS heading
//    error is below the array's on every seed run;
//  - one sensor + gyro: either refused with the estimator's message or
//    figures; its gyro-alone rows are the compact array's (same imu.csv);
//  - the rows' means are the means of their runs.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "moa/formats/config.hpp"
#include "moa/formats/log.hpp"
#include "support/json_value.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa {
namespace {

using test::JsonValue;

constexpr int kFirstSeed = 101;
constexpr int kRuns = 5;

const JsonValue& experiment() {
  static const JsonValue result = [] {
    const auto r = test::run_moa("experiment gyro --json --seed " + std::to_string(kFirstSeed) +
                                 " --runs " + std::to_string(kRuns));
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return JsonValue::parse(r.out);
  }();
  return result;
}

const JsonValue& row(const std::string& c, const std::string& method) {
  const JsonValue* found = nullptr;
  for (const auto& r : experiment()["rows"].array()) {
    if (r["case"].string() == c && r["method"].string() == method) {
      EXPECT_EQ(found, nullptr) << c << " " << method << " twice";
      found = &r;
    }
  }
  if (!found) throw std::runtime_error("no row " + c + " / " + method);
  return *found;
}

bool refused(const JsonValue& r) { return r.object().count("refused") > 0; }

/// The test's own truth heading at t: linear in the unwrapped theta.
double truth_heading(const std::vector<io::TruthRow>& truth, double t) {
  std::size_t i = 1;
  while (i + 1 < truth.size() && truth[i].t < t) ++i;
  const auto& a = truth[i - 1];
  const auto& b = truth[i];
  const double u = (t - a.t) / (b.t - a.t);
  return a.pose.theta + u * (b.pose.theta - a.pose.theta);
}

struct GyroHeading {
  double max = 0.0, rms = 0.0, final = 0.0;  ///< rad
};

/// imu.csv integrated with scale k, bias c, latency L against truth.csv.
GyroHeading integrate(const std::vector<io::ImuRow>& imu, const std::vector<io::TruthRow>& truth,
                      double k, double c, double latency) {
  GyroHeading h;
  double theta = truth_heading(truth, imu.front().t - latency);
  double sum_sq = 0.0;
  int n = 0;
  for (std::size_t j = 1; j < imu.size(); ++j) {
    theta += (imu[j].gz - c) / k * (imu[j].t - imu[j - 1].t);
    const double t = imu[j].t - latency;
    if (t < truth.front().t || t > truth.back().t) continue;
    const double e =
        std::abs(std::remainder(theta - truth_heading(truth, t), 2 * std::numbers::pi));
    h.max = std::max(h.max, e);
    h.final = e;
    sum_sq += e * e;
    ++n;
  }
  h.rms = std::sqrt(sum_sq / n);
  return h;
}

void header() {
  const JsonValue& e = experiment();
  EXPECT_EQ(e["experiment"].string(), "gyro");
  EXPECT_EQ(e["runs"].number(), kRuns);
  EXPECT_EQ(e["first_seed"].number(), kFirstSeed);
  EXPECT_EQ(e["last_seed"].number(), kFirstSeed + kRuns - 1);
  EXPECT_EQ(e["rows"].array().size(), 12u);  // 3 cases x 4 methods
}

void gyro_alone_against_the_tests_own_integration() {
  const auto dir = test::scratch_dir("gyro-experiment");
  const auto sim = test::run_moa("simulate --scenario gyro-compact --seed " +
                                 std::to_string(kFirstSeed) + " --out " + dir.string());
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  const auto believed = io::read_config(dir / "robot.yaml").imu.value();
  const auto real = io::read_config(dir / "robot.true.yaml").imu.value();
  const auto imu = io::read_all<io::ImuRow>(dir / "imu.csv");
  const auto truth = io::read_all<io::TruthRow>(dir / "truth.csv");
  ASSERT_GT(imu.size(), 1000u);
  // The experiment's gyro alone is robot.yaml's calibration integrated.
  const GyroHeading mine = integrate(imu, truth, believed.scale, believed.bias, believed.latency);
  const auto& run = row("compact array", "gyro alone")["runs"][0];
  ASSERT_EQ(run["seed"].number(), kFirstSeed);
  EXPECT_NEAR(run["max_heading_rad"].number(), mine.max, 1e-6);
  EXPECT_NEAR(run["rms_heading_rad"].number(), mine.rms, 1e-6);
  // The calibration is what it lacks: the true bias is far from robot.yaml's.
  ASSERT_GT(std::abs(real.bias - believed.bias), 0.005);
  // With the true scale, the final heading error is the bias error times
  // the run's length (the bias walk adds ~2e-4 rad/s over it: 5 %).
  const double T = imu.back().t - imu.front().t;
  for (const double db : {0.005, 0.02}) {
    const GyroHeading off = integrate(imu, truth, real.scale, real.bias + db, real.latency);
    EXPECT_NEAR(off.final, db * T, 0.1 * db * T) << "bias error " << db;
  }
  // The bias measured over the initial rest is the true one.
  const auto& rest = row("compact array", "gyro alone, bias at rest")["runs"][0];
  EXPECT_NEAR(rest["bias_rad_s"].number(), real.bias, 1e-3);
  EXPECT_LT(rest["max_heading_rad"].number(), run["max_heading_rad"].number());
}

void fused_beats_the_array_alone_on_the_compact_array() {
  const auto& fused = row("compact array", "fused")["runs"].array();
  const auto& array = row("compact array", "array alone")["runs"].array();
  ASSERT_EQ(fused.size(), static_cast<std::size_t>(kRuns));
  ASSERT_EQ(array.size(), fused.size());
  for (std::size_t k = 0; k < fused.size(); ++k) {
    ASSERT_EQ(fused[k]["seed"].number(), array[k]["seed"].number());
    EXPECT_LT(fused[k]["rms_heading_rad"].number(), array[k]["rms_heading_rad"].number())
        << "seed " << fused[k]["seed"].number();
  }
}

void one_sensor_is_refused_or_measured() {
  for (const char* method : {"array alone", "fused"}) {
    const auto& r = row("one sensor + gyro", method);
    EXPECT_EQ(r["sensors"].string(), "m1");
    if (refused(r)) {
      EXPECT_FALSE(r["refused"].string().empty()) << method;
    } else {
      EXPECT_EQ(r["runs"].array().size(), static_cast<std::size_t>(kRuns)) << method;
      EXPECT_TRUE(std::isfinite(r["max_heading_rad"].number())) << method;
    }
  }
  // The same imu.csv and truth.csv as the compact array's.
  for (const char* method : {"gyro alone", "gyro alone, bias at rest"}) {
    EXPECT_EQ(row("one sensor + gyro", method)["max_heading_rad"].number(),
              row("compact array", method)["max_heading_rad"].number())
        << method;
  }
}

void rows_are_the_means_of_their_runs() {
  for (const auto& r : experiment()["rows"].array()) {
    if (refused(r)) continue;
    const auto& runs = r["runs"].array();
    ASSERT_EQ(runs.size(), static_cast<std::size_t>(kRuns));
    for (const char* figure : {"max_heading_rad", "rms_heading_rad"}) {
      double sum = 0.0;
      for (const auto& run : runs) sum += run[figure].number();
      EXPECT_NEAR(r[figure].number(), sum / kRuns, 1e-12 * std::max(1.0, sum))
          << r["case"].string() << " " << r["method"].string() << " " << figure;
    }
  }
}

// One test: the experiment takes seconds, and ctest runs each test in a process of its own.
TEST(GyroExperiment, PropertiesOnTheTestSeeds) {
  {
    SCOPED_TRACE("seeds, runs and rows");
    header();
  }
  {
    SCOPED_TRACE("gyro alone");
    gyro_alone_against_the_tests_own_integration();
  }
  {
    SCOPED_TRACE("fused vs array alone");
    fused_beats_the_array_alone_on_the_compact_array();
  }
  {
    SCOPED_TRACE("one sensor");
    one_sensor_is_refused_or_measured();
  }
  {
    SCOPED_TRACE("rows and runs");
    rows_are_the_means_of_their_runs();
  }
}

}  // namespace
}  // namespace moa
