// `moa experiment self-calibration`: the online self-calibration
// (docs/self-calibration.md) on long simulated runs where one sensor's
// resolution changes: a linear drift (built-in scenario selfcal-ramp) and a
// step at a change of floor (selfcal-step). Each run is the consensus with
// and without `--self-calibrate`, and the oracle selection as the reference
// (simulated_run.hpp: every figure with the moa calls that reproduce it),
// and the affected sensor's estimated scale (self-calibration.csv, about
// once a second) against the scenario's true one at the same time.
//
// True scale of sensor i on axis a at time t, relative to its configured
// mount (the quantity self-calibration.csv estimates):
//   s_a(t) = (cpi_true scale_true,a) / (cpi_conf scale_conf,a) * prod_w g_w(t),
//   g_w(t) = 1 + (scale_w - 1) min(1, (t - start_w) / ramp_w)   (1 for ramp_w = 0)
// over the scenario's drift windows w of the sensor with start_w <= t < end_w
// (sim/optical.hpp). The self-calibration fixes its gauge by the median of
// the sensors' log scales; the other three are within 0.1 % of 1 in these
// scenarios, which is the ambiguity of the comparison.
#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "experiments_list.hpp"
#include "moa/experiments/simulated_run.hpp"
#include "moa/formats/json.hpp"
#include "moa/sim/scenario.hpp"

namespace moa::experiments {
namespace {

struct ScaleCase {
  const char* scenario;
  const char* describes;
};
const ScaleCase kCases[] = {
    {"selfcal-ramp", "m2's scale 1 -> 0.9 linearly over 40 s from t = 5 s, then held"},
    {"selfcal-step", "m2's scale steps 1 -> 0.9 at t = 20 s (a change of floor), then held"},
};
constexpr std::size_t kCaseCount = std::size(kCases);

struct MethodRow {
  const char* name;
  EstimatorKind estimator;
  bool self_calibrate;
};
const MethodRow kMethods[] = {{"consensus", EstimatorKind::kConsensus, false},
                              {"consensus + self-calibration", EstimatorKind::kConsensus, true},
                              {"oracle selection", EstimatorKind::kOracle, false}};
constexpr std::size_t kMethodCount = std::size(kMethods);
constexpr std::size_t kSelfCalibrated = 1;

/// The sensor the scenario's drift acts on (the first drift window's), and
/// its true scale over time (formula at the top of the file).
struct TrueScale {
  int sensor = -1;
  std::string name;
  double base[2] = {1.0, 1.0};  ///< truth / configured counts per metre, x and y
  std::vector<sim::FaultWindow> drifts;

  explicit TrueScale(const sim::Scenario& s) {
    for (std::size_t i = 0; i < s.faults.size() && sensor < 0; ++i) {
      for (const auto& w : s.faults[i].windows) {
        if (w.kind == sim::kFaultDrift) sensor = static_cast<int>(i);
      }
    }
    if (sensor < 0) return;
    const auto k = static_cast<std::size_t>(sensor);
    name = s.nominal.names[k];
    const SensorMount& truth = s.truth.array[sensor];
    const SensorMount& conf = s.nominal.array[sensor];
    for (int a = 0; a < 2; ++a) {
      base[a] = truth.cpi * truth.scale[a] / (conf.cpi * conf.scale[a]);
    }
    for (const auto& w : s.faults[k].windows) {
      if (w.kind == sim::kFaultDrift) drifts.push_back(w);
    }
  }
  double at(int axis, double t) const {
    double g = base[axis];
    for (const auto& w : drifts) {
      if (t < w.start || t >= w.end) continue;
      g *= 1.0 + (w.scale - 1.0) * (w.ramp > 0.0 ? std::min(1.0, (t - w.start) / w.ramp) : 1.0);
    }
    return g;
  }
};

/// One run's estimates of the affected sensor, in file order.
struct Series {
  std::uint64_t seed = 0;
  std::vector<double> t, scale_x, scale_y, yaw;
};

Series series_of(const RunRecord& r, const std::string& sensor) {
  Series s;
  s.seed = r.seed;
  for (const auto& row : r.calibration) {
    if (row.sensor != sensor) continue;
    s.t.push_back(row.t);
    s.scale_x.push_back(row.filter.scale_x);
    s.scale_y.push_back(row.filter.scale_y);
    s.yaw.push_back(row.filter.yaw_offset);
  }
  return s;
}

/// Mean and sd over the runs of sample k of each run's series (the runs of a
/// scenario share their epochs: the seed changes the noise, not the timing).
Spread sample(const std::vector<Series>& runs, std::vector<double> Series::*field, std::size_t k) {
  std::vector<double> v;
  for (const auto& r : runs) {
    if (k < (r.*field).size()) v.push_back((r.*field)[k]);
  }
  return spread(v);
}

void write_array(io::JsonWriter& json, const char* key, const std::vector<double>& values) {
  json.key(key).begin_array();
  for (const double v : values) json.value(v);
  json.end_array();
}

}  // namespace

Result self_calibration(const Options& options) {
  const int runs = options.runs > 0 ? options.runs : 5;
  std::vector<RunRecord> records[kCaseCount][kMethodCount];
  std::vector<Series> series[kCaseCount];
  std::vector<TrueScale> truth;
  ScratchDirectory scratch("moa-self-calibration");
  for (std::size_t c = 0; c < kCaseCount; ++c) {
    truth.emplace_back(sim::load_scenario(kCases[c].scenario));
    for (int k = 0; k < runs; ++k) {
      if (options.progress) {
        options.progress(fmt::format("{}: run {}/{}", kCases[c].scenario, k + 1, runs));
      }
      const SimulatedRun run(kCases[c].scenario, options.seed + static_cast<std::uint64_t>(k),
                             scratch.path());
      for (std::size_t m = 0; m < kMethodCount; ++m) {
        const MethodRow& row = kMethods[m];
        records[c][m].push_back(
            run.run(method_of(row.name, row.estimator, row.self_calibrate), row.self_calibrate));
      }
      series[c].push_back(series_of(records[c][kSelfCalibrated].back(), truth[c].name));
    }
  }
  const std::uint64_t last = options.seed + static_cast<std::uint64_t>(runs) - 1;

  io::JsonWriter json;
  json.begin_object().member("experiment", "self-calibration").member("runs", runs);
  json.member("first_seed", options.seed).member("last_seed", last);
  json.key("rows").begin_array();
  for (std::size_t c = 0; c < kCaseCount; ++c) {
    for (std::size_t m = 0; m < kMethodCount; ++m) {
      json.begin_object().member("scenario", kCases[c].scenario).member("method", kMethods[m].name);
      write_runs(json, records[c][m]);
      json.end_object();
    }
  }
  json.end_array();
  // The affected sensor's scale over time: the scenario's true value at each
  // sample's time (of the first run) and the estimates' mean and sd over the
  // runs, then each run's own series.
  json.key("scale").begin_array();
  for (std::size_t c = 0; c < kCaseCount; ++c) {
    const TrueScale& ts = truth[c];
    const Series& first = series[c].front();
    std::vector<double> true_x, true_y, mean_x, mean_y, sd_x, sd_y;
    for (std::size_t k = 0; k < first.t.size(); ++k) {
      true_x.push_back(ts.at(0, first.t[k]));
      true_y.push_back(ts.at(1, first.t[k]));
      const Spread x = sample(series[c], &Series::scale_x, k);
      const Spread y = sample(series[c], &Series::scale_y, k);
      mean_x.push_back(x.mean);
      mean_y.push_back(y.mean);
      sd_x.push_back(x.sd);
      sd_y.push_back(y.sd);
    }
    json.begin_object().member("scenario", kCases[c].scenario).member("sensor", ts.name);
    write_array(json, "t_s", first.t);
    write_array(json, "true_scale_x", true_x);
    write_array(json, "true_scale_y", true_y);
    write_array(json, "mean_scale_x", mean_x);
    write_array(json, "mean_scale_y", mean_y);
    write_array(json, "sd_scale_x", sd_x);
    write_array(json, "sd_scale_y", sd_y);
    json.key("runs").begin_array();
    for (const auto& s : series[c]) {
      json.begin_object().member("seed", s.seed);
      write_array(json, "t_s", s.t);
      write_array(json, "scale_x", s.scale_x);
      write_array(json, "scale_y", s.scale_y);
      write_array(json, "yaw_offset_rad", s.yaw);
      json.end_object();
    }
    json.end_array().end_object();
  }
  json.end_array().end_object();

  std::string text = fmt::format(
      "Online self-calibration on the simulator: four HDNS-2051 on a radial array of 0.1 m,\n"
      "four laps of a 0.5 m square at speed (a), one sensor's scale changing; mean over {} runs\n"
      "(seeds {}..{}) of the maximum and final translation error (mm) and maximum heading\n"
      "error (deg), +- the sd over the runs.\n",
      runs, options.seed, last);
  for (std::size_t c = 0; c < kCaseCount; ++c) {
    const TrueScale& ts = truth[c];
    text += fmt::format("\n{}: {}\n", kCases[c].scenario, kCases[c].describes);
    text += fmt::format("{:<30} | {:>15} | {:>15} | {:>7}\n", "method", "max mm", "final mm",
                        "max deg");
    for (std::size_t m = 0; m < kMethodCount; ++m) {
      const MeanError e = mean_error(records[c][m]);
      text += fmt::format("{:<30} | {:>6.1f} +- {:>5.1f} | {:>6.1f} +- {:>5.1f} | {:>7.2f}\n",
                          kMethods[m].name, 1e3 * e.max_translation.mean,
                          1e3 * e.max_translation.sd, 1e3 * e.final_translation.mean,
                          1e3 * e.final_translation.sd, to_degrees(e.max_heading.mean));
    }
    // The scale table, every 5th sample (about every 5 s) and the last.
    const Series& first = series[c].front();
    text += fmt::format(
        "\n{}'s scale: the scenario's true value and the estimate (mean +- sd over the runs)\n",
        ts.name);
    text += fmt::format("{:>7} | {:>6} {:>17} | {:>6} {:>17} | {:>15}\n", "t s", "true x",
                        "estimated x", "true y", "estimated y", "yaw offset mrad");
    for (std::size_t k = 0; k < first.t.size(); ++k) {
      if (k % 5 != 0 && k + 1 != first.t.size()) continue;
      const Spread x = sample(series[c], &Series::scale_x, k);
      const Spread y = sample(series[c], &Series::scale_y, k);
      const Spread yaw = sample(series[c], &Series::yaw, k);
      text += fmt::format(
          "{:>7.2f} | {:>6.4f} {:>7.4f} +- {:>6.4f} | {:>6.4f} {:>7.4f} +- {:>6.4f} | {:>15.2f}\n",
          first.t[k], ts.at(0, first.t[k]), x.mean, x.sd, ts.at(1, first.t[k]), y.mean, y.sd,
          1e3 * yaw.mean);
    }
  }
  // Conclusions, computed: the final estimate's relative error, and the paired
  // difference of the max error with and without self-calibration (mean and
  // its standard error over the runs), beside the oracle.
  text += "\n";
  for (std::size_t c = 0; c < kCaseCount; ++c) {
    const TrueScale& ts = truth[c];
    double worst = 0.0;
    for (const auto& s : series[c]) {
      if (s.t.empty()) continue;
      for (int a = 0; a < 2; ++a) {
        const double est = a == 0 ? s.scale_x.back() : s.scale_y.back();
        const double tru = ts.at(a, s.t.back());
        worst = std::max(worst, std::abs(est / tru - 1.0));
      }
    }
    std::vector<double> d;
    for (int k = 0; k < runs; ++k) {
      const auto kk = static_cast<std::size_t>(k);
      d.push_back(records[c][kSelfCalibrated][kk].error.max_translation -
                  records[c][0][kk].error.max_translation);
    }
    const Spread diff = spread(d);
    const double oracle = mean_error(records[c][2]).max_translation.mean;
    text += fmt::format(
        "{}: final estimate of {}'s scale within {:.2f} % of the true one (worst axis and run);\n"
        "  max error with self-calibration minus without: {:+.1f} +- {:.1f} mm (mean +- its "
        "standard error); oracle {:.1f} mm\n",
        kCases[c].scenario, ts.name, 100.0 * worst, 1e3 * diff.mean,
        1e3 * diff.sd / std::sqrt(static_cast<double>(runs)), 1e3 * oracle);
  }
  text += "Each run's figures, the estimates and the moa calls that reproduce them: --json.\n";
  return {text, json.str() + "\n"};
}

}  // namespace moa::experiments
