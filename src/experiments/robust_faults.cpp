// `moa experiment robust-faults`: every fault the simulator makes, one kind
// at a time (built-in scenarios faults-*: a 2 s window on each sensor in
// turn along the Table 3 path at speed (a); tracking loss is speed (b)'s own
// over-speed fault; drift, linear or a step at a change of floor, on one
// sensor for the rest of the run; a register frozen in a cruise while
// another sensor drifts slowly, faults-cruise; a resolution set wrong from
// the start, faults-runaway; every sensor at once over a bump, faults-bump), against plain least
// squares, Sekimori & Miyazaki's voting, the consensus, the consensus with online self-calibration
// (`--self-calibrate`) and oracle selection.
#include <fmt/core.h>

#include <numbers>
#include <string>
#include <vector>

#include "experiments_list.hpp"
#include "moa/experiments/simulated_run.hpp"
#include "moa/formats/json.hpp"

namespace moa::experiments {
namespace {

struct FaultCase {
  const char* name;
  const char* scenario;
  const char* describes;
};
const FaultCase kCases[] = {
    {"tracking loss", "sekimori-b", "over the rated speed, 0-50 % of the counts (speed (b))"},
    {"liftoff, no flag", "faults-liftoff", "zero counts, SQUAL 3, lift flag not set"},
    {"dirty floor", "faults-dirty", "30 % of the counts, SQUAL 15"},
    {"spikes", "faults-spikes", "20 jumps/s of 30 counts"},
    {"stuck", "faults-stuck", "counts frozen at the last frame's"},
    {"zero reading", "faults-zero", "zero counts, SQUAL 80, no lift flag"},
    {"drift", "faults-drift", "m2's scale 1 -> 0.9 over 6 s from t = 1 s, then held"},
    {"drift, step", "faults-floor", "m2's scale steps 1 -> 0.9 at t = 5 s (change of floor)"},
    {"frozen, other drifts", "faults-cruise",
     "m2's scale 1 -> 0.9 over 90 s, m3 frozen 3 s in a cruise, 24 m run, noisy wheels"},
    {"runaway", "faults-runaway",
     "m2 built at 1020 cpi, configured at 800: 1.275 times the counts from t = 0"},
    {"common-mode dropout", "faults-bump",
     "every sensor reads zero for 0.3 s in three turns, 36 m run, slipping wheels"},
};

struct MethodRow {
  const char* name;
  const char* column;  ///< the table's header
  EstimatorKind estimator;
  bool self_calibrate;
};
const MethodRow kMethods[] = {
    {"least squares, all", "least squares, all", EstimatorKind::kLs, false},
    {"voting (Sekimori)", "voting (Sekimori)", EstimatorKind::kSekimori, false},
    {"consensus", "consensus", EstimatorKind::kConsensus, false},
    {"consensus + self-calibration", "+ self-calibration", EstimatorKind::kConsensus, true},
    {"oracle selection", "oracle selection", EstimatorKind::kOracle, false}};
constexpr std::size_t kConsensus = 2, kSelfCalibrated = 3, kOracle = 4;
constexpr std::size_t kMethodCount = std::size(kMethods);
constexpr std::size_t kCaseCount = std::size(kCases);

}  // namespace

Result robust_faults(const Options& options) {
  const int runs = options.runs > 0 ? options.runs : 5;
  std::vector<RunRecord> records[kCaseCount][kMethodCount];
  ScratchDirectory scratch("moa-robust-faults");
  for (std::size_t c = 0; c < kCaseCount; ++c) {
    for (int k = 0; k < runs; ++k) {
      if (options.progress) {
        options.progress(fmt::format("{}: run {}/{}", kCases[c].name, k + 1, runs));
      }
      const SimulatedRun run(kCases[c].scenario, options.seed + static_cast<std::uint64_t>(k),
                             scratch.path());
      for (std::size_t m = 0; m < kMethodCount; ++m) {
        const MethodRow& row = kMethods[m];
        records[c][m].push_back(run.run(method_of(row.name, row.estimator, row.self_calibrate)));
      }
    }
  }
  const std::uint64_t last = options.seed + static_cast<std::uint64_t>(runs) - 1;
  io::JsonWriter json;
  json.begin_object().member("experiment", "robust-faults").member("runs", runs);
  json.member("first_seed", options.seed).member("last_seed", last);
  json.key("rows").begin_array();
  for (std::size_t c = 0; c < kCaseCount; ++c) {
    for (std::size_t m = 0; m < kMethodCount; ++m) {
      json.begin_object()
          .member("fault", kCases[c].name)
          .member("scenario", kCases[c].scenario)
          .member("method", kMethods[m].name);
      write_runs(json, records[c][m]);
      json.end_object();
    }
  }
  json.end_array().end_object();

  std::string text = fmt::format(
      "Each simulated fault alone on the Table 3 path, four HDNS-2051; mean over {} runs\n"
      "(seeds {}..{}) of the maximum translation (mm) and heading (deg) error.\n\n",
      runs, options.seed, last);
  text += fmt::format("{:<19}", "fault");
  for (const auto& m : kMethods) text += fmt::format(" | {:>18}", m.column);
  text += "\n";
  for (std::size_t c = 0; c < kCaseCount; ++c) {
    text += fmt::format("{:<19}", kCases[c].name);
    for (std::size_t m = 0; m < kMethodCount; ++m) {
      const MeanError e = mean_error(records[c][m]);
      text += fmt::format(" | {:>8.1f} {:>5.2f} deg", 1e3 * e.max_translation.mean,
                          to_degrees(e.max_heading.mean));
    }
    text += "\n";
  }
  // Conclusions, computed: where the consensus is within two standard errors
  // of the oracle's mean (sd over runs / sqrt(runs), both added), and where not.
  text += "\n";
  for (std::size_t c = 0; c < kCaseCount; ++c) {
    const MeanError consensus = mean_error(records[c][kConsensus]);
    const MeanError oracle = mean_error(records[c][kOracle]);
    const double se = std::sqrt((consensus.max_translation.sd * consensus.max_translation.sd +
                                 oracle.max_translation.sd * oracle.max_translation.sd) /
                                runs);
    const double gap = consensus.max_translation.mean - oracle.max_translation.mean;
    text += fmt::format("{}: consensus {:.1f} mm vs oracle {:.1f} mm: {}\n", kCases[c].name,
                        1e3 * consensus.max_translation.mean, 1e3 * oracle.max_translation.mean,
                        gap <= 2.0 * se ? "at the oracle (within 2 standard errors)"
                                        : fmt::format("{:.1f} mm worse ({:.1f} standard errors)",
                                                      1e3 * gap, se > 0 ? gap / se : 0.0));
  }
  // The consensus with self-calibration against without it: the paired
  // difference of the max error per seed, its mean and standard error.
  text += "\n";
  for (std::size_t c = 0; c < kCaseCount; ++c) {
    std::vector<double> d;
    for (std::size_t k = 0; k < records[c][kConsensus].size(); ++k) {
      d.push_back(records[c][kSelfCalibrated][k].error.max_translation -
                  records[c][kConsensus][k].error.max_translation);
    }
    const Spread diff = spread(d);
    text += fmt::format(
        "{}: self-calibration changes the consensus's max error by {:+.1f} +- {:.1f} mm (paired "
        "mean +- its standard error)\n",
        kCases[c].name, 1e3 * diff.mean, 1e3 * diff.sd / std::sqrt(static_cast<double>(runs)));
  }
  text += "\n";
  for (const auto& c : kCases) text += fmt::format("{}: {}\n", c.name, c.describes);
  return {text, json.str() + "\n"};
}

}  // namespace moa::experiments
