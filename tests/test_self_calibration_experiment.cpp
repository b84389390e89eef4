// `moa experiment self-calibration` (docs/experiments.md) on the test seeds
// 101-105, checked against what the test computes itself:
//  - the true scale: from the built-in scenario (truth and configured
//    resolution, the drift windows' gain formula of docs/simulator.md),
//    evaluated here at the experiment's sample times;
//  - the estimate follows it: within 2 % of the true scale at every sample
//    before the change and from 5 s after the change has ended, on both axes
//    and in every run (the estimator's scatter on a clean log is 0.5 %,
//    docs/self-calibration.md; the rest is the gauge and the lag of the
//    random walk);
//  - the pose error with self-calibration is not worse than without: a
//    paired one-sided t bound at 99 % on the per-seed max errors, plus the
//    0.5 mm quantisation floor of the experiments' tests;
//  - the rows' means are the means of their runs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "moa/sim/scenario.hpp"
#include "support/json_value.hpp"
#include "support/run.hpp"

namespace moa {
namespace {

using test::JsonValue;

constexpr int kFirstSeed = 101;
constexpr int kRuns = 5;
constexpr double kT99Dof4 = 3.747;  ///< one-sided Student t, 99 %, 4 degrees of freedom
constexpr double kFloor = 5e-4;     ///< m

const JsonValue& experiment() {
  static const JsonValue result = [] {
    const auto r = test::run_moa("experiment self-calibration --json --seed " +
                                 std::to_string(kFirstSeed) + " --runs " + std::to_string(kRuns));
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return JsonValue::parse(r.out);
  }();
  return result;
}

/// The scenario's true scale of `sensor` on `axis` at time t, relative to
/// its configured resolution, and when its last drift window's change ends.
struct Truth {
  sim::Scenario s;
  int sensor = -1;
  double change_start = 0.0, change_end = 0.0;  ///< s

  Truth(const std::string& scenario, const std::string& name)
      : s(sim::load_scenario(scenario)), sensor(*s.nominal.index_of(name)) {
    for (const auto& w : s.faults[static_cast<std::size_t>(sensor)].windows) {
      EXPECT_EQ(w.kind, sim::kFaultDrift);
      change_start = w.start;
      change_end = w.start + w.ramp;
    }
  }
  double at(int axis, double t) const {
    const SensorMount& truth = s.truth.array[sensor];
    const SensorMount& conf = s.nominal.array[sensor];
    double g = truth.cpi * truth.scale[axis] / (conf.cpi * conf.scale[axis]);
    for (const auto& w : s.faults[static_cast<std::size_t>(sensor)].windows) {
      if (t >= w.start && t < w.end) {
        const double progress = w.ramp > 0.0 ? std::min(1.0, (t - w.start) / w.ramp) : 1.0;
        g *= 1.0 + (w.scale - 1.0) * progress;
      }
    }
    return g;
  }
};

const JsonValue& row(const std::string& scenario, const std::string& method) {
  const JsonValue* found = nullptr;
  for (const auto& r : experiment()["rows"].array()) {
    if (r["scenario"].string() == scenario && r["method"].string() == method) {
      EXPECT_EQ(found, nullptr) << scenario << " " << method << " twice";
      found = &r;
    }
  }
  if (!found) throw std::runtime_error("no row " + scenario + " / " + method);
  return *found;
}

void seeds_runs_and_scenarios() {
  const JsonValue& e = experiment();
  EXPECT_EQ(e["experiment"].string(), "self-calibration");
  EXPECT_EQ(e["runs"].number(), kRuns);
  EXPECT_EQ(e["first_seed"].number(), kFirstSeed);
  EXPECT_EQ(e["last_seed"].number(), kFirstSeed + kRuns - 1);
  ASSERT_EQ(e["scale"].array().size(), 2u);
  EXPECT_EQ(e["scale"][0]["scenario"].string(), "selfcal-ramp");
  EXPECT_EQ(e["scale"][1]["scenario"].string(), "selfcal-step");
}

void estimated_scale_follows_the_scenarios_true_scale() {
  for (const auto& scale : experiment()["scale"].array()) {
    const std::string scenario = scale["scenario"].string();
    const Truth truth(scenario, scale["sensor"].string());
    ASSERT_GT(truth.change_start, 1.0) << scenario;
    // The experiment's true columns are the scenario's.
    const auto t = scale["t_s"].numbers();
    const auto true_x = scale["true_scale_x"].numbers();
    const auto true_y = scale["true_scale_y"].numbers();
    ASSERT_EQ(true_x.size(), t.size());
    ASSERT_EQ(true_y.size(), t.size());
    for (std::size_t k = 0; k < t.size(); ++k) {
      EXPECT_NEAR(true_x[k], truth.at(0, t[k]), 1e-12) << scenario << " t " << t[k];
      EXPECT_NEAR(true_y[k], truth.at(1, t[k]), 1e-12) << scenario << " t " << t[k];
    }
    // About once a second over the whole run (docs/formats/log.md).
    ASSERT_GE(t.size(), 50u) << scenario;
    const auto& runs = scale["runs"].array();
    ASSERT_EQ(runs.size(), static_cast<std::size_t>(kRuns));
    for (const auto& run : runs) {
      const int seed = static_cast<int>(run["seed"].number());
      const auto rt = run["t_s"].numbers();
      const auto sx = run["scale_x"].numbers();
      const auto sy = run["scale_y"].numbers();
      ASSERT_EQ(sx.size(), rt.size());
      ASSERT_EQ(sy.size(), rt.size());
      int checked = 0;
      for (std::size_t k = 0; k < rt.size(); ++k) {
        if (rt[k] >= truth.change_start && rt[k] < truth.change_end + 5.0) continue;
        ++checked;
        EXPECT_NEAR(sx[k] / truth.at(0, rt[k]), 1.0, 0.02)
            << scenario << " seed " << seed << " t " << rt[k];
        EXPECT_NEAR(sy[k] / truth.at(1, rt[k]), 1.0, 0.02)
            << scenario << " seed " << seed << " t " << rt[k];
      }
      // The last sample, after the change, is among those checked.
      EXPECT_GE(rt.back(), truth.change_end + 5.0) << scenario;
      EXPECT_GE(checked, 10) << scenario;
      // The change is really there: the final true scale is 10 % off the
      // start's, far beyond the 2 % tolerance.
      EXPECT_LT(truth.at(0, rt.back()), 0.92 * truth.at(0, 0.0));
    }
  }
}

void self_calibration_is_not_worse_than_without() {
  for (const char* scenario : {"selfcal-ramp", "selfcal-step"}) {
    const auto& with = row(scenario, "consensus + self-calibration")["runs"].array();
    const auto& without = row(scenario, "consensus")["runs"].array();
    ASSERT_EQ(with.size(), static_cast<std::size_t>(kRuns));
    ASSERT_EQ(without.size(), with.size());
    std::vector<double> d;
    for (std::size_t k = 0; k < with.size(); ++k) {
      ASSERT_EQ(with[k]["seed"].number(), without[k]["seed"].number());
      d.push_back(with[k]["max_translation_m"].number() - without[k]["max_translation_m"].number());
    }
    const double n = static_cast<double>(d.size());
    double mean = 0.0;
    for (const double x : d) mean += x / n;
    double var = 0.0;
    for (const double x : d) var += (x - mean) * (x - mean) / (n - 1.0);
    EXPECT_LE(mean, kT99Dof4 * std::sqrt(var / n) + kFloor) << scenario;
  }
}

void rows_are_the_means_of_their_runs() {
  for (const auto& r : experiment()["rows"].array()) {
    const auto& runs = r["runs"].array();
    ASSERT_EQ(runs.size(), static_cast<std::size_t>(kRuns));
    for (const char* figure : {"max_translation_m", "final_translation_m", "max_heading_rad"}) {
      double sum = 0.0;
      for (const auto& run : runs) sum += run[figure].number();
      EXPECT_NEAR(r[figure].number(), sum / kRuns, 1e-12 * std::max(1.0, sum))
          << r["scenario"].string() << " " << r["method"].string() << " " << figure;
    }
    // Each run is reproduced by a simulate, an odometry and an evaluate call.
    for (const auto& run : runs) ASSERT_EQ(run["reproduce"].array().size(), 3u);
  }
}

// One test: the experiment takes seconds, and ctest runs each test in a process of its own.
TEST(SelfCalibrationExperiment, PropertiesOnTheTestSeeds) {
  {
    SCOPED_TRACE("seeds, runs and scenarios");
    seeds_runs_and_scenarios();
  }
  {
    SCOPED_TRACE("estimated vs true scale");
    estimated_scale_follows_the_scenarios_true_scale();
  }
  {
    SCOPED_TRACE("pose error with and without");
    self_calibration_is_not_worse_than_without();
  }
  {
    SCOPED_TRACE("rows and runs");
    rows_are_the_means_of_their_runs();
  }
}

}  // namespace
}  // namespace moa
