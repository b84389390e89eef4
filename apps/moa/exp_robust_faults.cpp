// `moa experiment robust-faults`: every fault the simulator can make, one at
// a time, against plain least squares, Sekimori & Miyazaki's voting, the
// consensus, and oracle selection (docs/experiments.md).
#include <fmt/core.h>

#include <array>
#include <numbers>
#include <string>
#include <vector>

#include "experiments.hpp"
#include "moa/sim/optical.hpp"
#include "moa/sim/scenario.hpp"
#include "moa/sim/simulate.hpp"
#include "replay.hpp"

namespace moa::cli {
namespace {

constexpr double kDeg = 180.0 / std::numbers::pi;

struct FaultCase {
  const char* name;
  const char* scenario;   ///< built-in scenario the fault is put on
  sim::FaultBit kind;     ///< window fault; kFaultTrackingLoss: the scenario's own
  const char* describes;  ///< for the table's legend
};

// Window faults: one 2 s window on each sensor in turn (m2, m3, m4, m1) along
// the Table 3 path at speed (a), where nothing else fails; tracking loss is
// speed (b)'s own over-speed fault.
const std::vector<FaultCase>& fault_cases() {
  static const std::vector<FaultCase> cases{
      {"tracking loss", "sekimori-b", sim::kFaultTrackingLoss,
       "over the rated speed, 0-50 % of the counts (speed (b))"},
      {"liftoff, no flag", "sekimori-a", sim::kFaultLiftoff,
       "zero counts, SQUAL 3, lift flag not set"},
      {"dirty floor", "sekimori-a", sim::kFaultDirty, "30 % of the counts, SQUAL 15"},
      {"spikes", "sekimori-a", sim::kFaultSpike, "20 jumps/s of 30 counts"},
      {"stuck", "sekimori-a", sim::kFaultStuck, "counts frozen at the last frame's"},
  };
  return cases;
}

sim::Scenario with_fault(const FaultCase& c) {
  sim::Scenario s = sim::load_scenario(c.scenario);
  if (c.kind == sim::kFaultTrackingLoss) return s;
  const double windows[4][2] = {{1.0, 3.0}, {5.0, 7.0}, {9.0, 11.0}, {13.0, 15.0}};
  const int sensor_of_window[4] = {1, 2, 3, 0};
  for (auto& f : s.faults) f = {};
  for (int w = 0; w < 4; ++w) {
    sim::FaultWindow window;
    window.kind = c.kind;
    window.start = windows[w][0];
    window.end = windows[w][1];
    window.retained = 0.3;
    window.squal = c.kind == sim::kFaultLiftoff ? 3 : 15;
    window.rate = 20.0;
    window.magnitude = 30.0;
    window.lift_flag = false;
    s.faults[static_cast<std::size_t>(sensor_of_window[w])].windows.push_back(window);
  }
  return s;
}

struct Method {
  const char* name;
  ReplayMethod method;
};
constexpr Method kMethods[] = {{"least squares, all", ReplayMethod::kLs},
                               {"voting (Sekimori)", ReplayMethod::kSekimori},
                               {"consensus", ReplayMethod::kConsensus},
                               {"oracle selection", ReplayMethod::kOracle}};
constexpr std::size_t kMethodCount = std::size(kMethods);

int run_robust_faults(const ExperimentOptions& options) {
  const int runs = options.runs > 0 ? options.runs : 5;
  const auto& cases = fault_cases();
  std::vector<std::array<double, kMethodCount>> mm(cases.size()), deg(cases.size());
  for (std::size_t c = 0; c < cases.size(); ++c) {
    const sim::Scenario scenario = with_fault(cases[c]);
    mm[c].fill(0.0);
    deg[c].fill(0.0);
    for (int run = 0; run < runs; ++run) {
      const sim::SimLog log =
          sim::simulate(scenario, options.seed + static_cast<std::uint64_t>(run));
      for (std::size_t m = 0; m < kMethodCount; ++m) {
        ReplayOptions o;
        o.method = kMethods[m].method;
        const TrajectoryError e = replay(log, scenario.nominal, o);
        mm[c][m] += 1e3 * e.max_translation / runs;
        deg[c][m] += kDeg * e.max_heading / runs;
      }
    }
  }
  if (options.json) {
    std::string rows;
    for (std::size_t c = 0; c < cases.size(); ++c) {
      for (std::size_t m = 0; m < kMethodCount; ++m) {
        if (!rows.empty()) rows += ", ";
        rows += fmt::format(
            "{{\"fault\": \"{}\", \"method\": \"{}\", \"max_translation_m\": {:.6g}, "
            "\"max_heading_rad\": {:.6g}}}",
            cases[c].name, kMethods[m].name, mm[c][m] / 1e3, deg[c][m] / kDeg);
      }
    }
    fmt::print("{{\"experiment\": \"robust-faults\", \"runs\": {}, \"rows\": [{}]}}\n", runs, rows);
    return 0;
  }
  fmt::print(
      "Each simulated fault alone on the Table 3 path, four HDNS-2051; mean over {} runs\n"
      "(seeds {}..{}) of the maximum translation (mm) and heading (deg) error.\n\n",
      runs, options.seed, options.seed + static_cast<std::uint64_t>(runs) - 1);
  fmt::print("{:<18}", "fault");
  for (const auto& m : kMethods) fmt::print(" | {:>18}", m.name);
  fmt::print("\n");
  for (std::size_t c = 0; c < cases.size(); ++c) {
    fmt::print("{:<18}", cases[c].name);
    for (std::size_t m = 0; m < kMethodCount; ++m) {
      fmt::print(" | {:>8.1f} {:>5.2f} deg", mm[c][m], deg[c][m]);
    }
    fmt::print("\n");
  }
  fmt::print("\n");
  for (const auto& c : cases) fmt::print("{}: {}\n", c.name, c.describes);
  return 0;
}

const ExperimentRegistration kRegistered{
    "robust-faults",
    "Each simulated sensor fault alone: least squares, voting, consensus, oracle (default 5 runs)",
    run_robust_faults};

}  // namespace
}  // namespace moa::cli
