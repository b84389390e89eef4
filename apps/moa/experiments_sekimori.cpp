#include "experiments_sekimori.hpp"

#include <fmt/core.h>
#include <unistd.h>

#include <cmath>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "experiments.hpp"
#include "moa/sim/scenario.hpp"
#include "moa/sim/simulate.hpp"
#include "replay.hpp"

namespace moa::cli {
namespace {

constexpr double kDeg = 180.0 / std::numbers::pi;

struct Method {
  const char* name;
  ReplayMethod method;
  SensorMask mask;
  std::optional<double> paper_mm[2];  ///< speeds (a), (b)
  std::optional<double> paper_deg[2];
};

// reference/papers.md, Table 4.
const std::vector<Method>& table4_methods() {
  static const std::vector<Method> m{
      {"wheels", ReplayMethod::kWheels, 0u, {191.499, 239.397}, {14.970, 19.264}},
      {"2 mice", ReplayMethod::kLs, 0b0101u, {44.516, 627.237}, {4.918, 40.638}},
      {"4 mice, voting (Sekimori)",
       ReplayMethod::kSekimori,
       0b1111u,
       {38.011, 61.593},
       {4.607, 8.588}},
      {"4 mice, consensus", ReplayMethod::kConsensus, 0b1111u, {}, {}},
      {"4 mice, oracle selection", ReplayMethod::kOracle, 0b1111u, {}, {}},
  };
  return m;
}

std::string figure(const std::optional<double>& x) {
  return x ? fmt::format("{:.1f}", *x) : std::string("-");
}

void progress(const char* what, int done, int total) {
  if (isatty(STDERR_FILENO)) fmt::print(stderr, "\r{}: run {}/{}", what, done, total);
  if (isatty(STDERR_FILENO) && done == total) fmt::print(stderr, "\r\033[K");
}

}  // namespace

int run_sekimori_table4(int runs, std::uint64_t seed, bool json) {
  const char* speeds[2] = {"a", "b"};
  const auto& methods = table4_methods();
  // mean over runs of the max errors: [speed][method]
  std::vector<std::vector<double>> mm(2, std::vector<double>(methods.size(), 0.0));
  std::vector<std::vector<double>> deg = mm;
  for (int s = 0; s < 2; ++s) {
    const sim::Scenario scenario = sim::load_scenario(std::string("sekimori-") + speeds[s]);
    for (int run = 1; run <= runs; ++run) {
      progress(speeds[s] == std::string("a") ? "table 4, speed (a)" : "table 4, speed (b)", run,
               runs);
      const sim::SimLog log = sim::simulate(scenario, seed + static_cast<std::uint64_t>(run - 1));
      for (std::size_t m = 0; m < methods.size(); ++m) {
        ReplayOptions o;
        o.method = methods[m].method;
        o.mask = methods[m].mask;
        const TrajectoryError e = replay(log, scenario.nominal, o);
        mm[static_cast<std::size_t>(s)][m] += 1e3 * e.max_translation / runs;
        deg[static_cast<std::size_t>(s)][m] += kDeg * e.max_heading / runs;
      }
    }
  }
  if (json) {
    std::string rows;
    for (int s = 0; s < 2; ++s) {
      for (std::size_t m = 0; m < methods.size(); ++m) {
        if (!rows.empty()) rows += ", ";
        const auto& p = methods[m];
        rows += fmt::format(
            "{{\"speed\": \"{}\", \"method\": \"{}\", \"max_translation_m\": {:.6g}, "
            "\"max_heading_rad\": {:.6g}, \"paper_max_translation_m\": {}, "
            "\"paper_max_heading_rad\": {}}}",
            speeds[s], p.name, mm[static_cast<std::size_t>(s)][m] / 1e3,
            deg[static_cast<std::size_t>(s)][m] / kDeg,
            p.paper_mm[s] ? fmt::format("{:.6g}", *p.paper_mm[s] / 1e3) : "null",
            p.paper_deg[s] ? fmt::format("{:.6g}", *p.paper_deg[s] / kDeg) : "null");
      }
    }
    fmt::print("{{\"experiment\": \"sekimori-table4\", \"runs\": {}, \"rows\": [{}]}}\n", runs,
               rows);
    return 0;
  }
  fmt::print(
      "Sekimori & Miyazaki Table 4 on the simulator: average over {} runs of the maximum\n"
      "error along the Table 3 path (seeds {}..{}). Paper: their robot and floor.\n\n",
      runs, seed, seed + static_cast<std::uint64_t>(runs) - 1);
  fmt::print("{:<6} {:<27} | {:>10} {:>10} | {:>10} {:>10}\n", "speed", "method", "ours mm",
             "paper mm", "ours deg", "paper deg");
  for (int s = 0; s < 2; ++s) {
    for (std::size_t m = 0; m < methods.size(); ++m) {
      const auto& p = methods[m];
      fmt::print("({})    {:<27} | {:>10.1f} {:>10} | {:>10.2f} {:>10}\n", speeds[s], p.name,
                 mm[static_cast<std::size_t>(s)][m], figure(p.paper_mm[s]),
                 deg[static_cast<std::size_t>(s)][m], figure(p.paper_deg[s]));
    }
  }
  return 0;
}

int run_sekimori_fig6(int runs, std::uint64_t seed, bool json) {
  const sim::Scenario scenario = sim::load_scenario("sekimori-b");
  struct Row {
    const char* name;
    double max_m = 0, rms_m = 0, max_rad = 0, rms_rad = 0;
    bool heading = true;
  };
  std::vector<Row> rows{{"camera alone"},
                        {"wheel dead reckoning"},
                        {"wheels + camera (EKF)"},
                        {"mouse dead reckoning (consensus)"},
                        {"mice + camera (EKF)"}};
  rows[0].heading = false;
  for (int run = 1; run <= runs; ++run) {
    progress("fig. 6, speed (b)", run, runs);
    const sim::SimLog log = sim::simulate(scenario, seed + static_cast<std::uint64_t>(run - 1));
    // Camera alone: each fix against the truth at its capture time.
    std::vector<StampedPose> truth;
    for (const auto& r : log.truth) truth.push_back({r.t, r.pose});
    TrajectoryErrorAccumulator cam(truth);
    for (const auto& f : log.camera) {
      const auto at = interpolate(truth, f.t);
      if (at) cam.add(f.t, Pose2{f.position, at->theta});
    }
    std::vector<TrajectoryError> e{cam.result()};
    const std::pair<ReplayMethod, bool> cases[4] = {{ReplayMethod::kWheels, false},
                                                    {ReplayMethod::kWheels, true},
                                                    {ReplayMethod::kConsensus, false},
                                                    {ReplayMethod::kConsensus, true}};
    for (const auto& [method, fuse] : cases) {
      ReplayOptions o;
      o.method = method;
      o.fuse_camera = fuse;
      e.push_back(replay(log, scenario.nominal, o));
    }
    for (std::size_t k = 0; k < rows.size(); ++k) {
      rows[k].max_m += e[k].max_translation / runs;
      rows[k].rms_m += e[k].rms_translation / runs;
      rows[k].max_rad += e[k].max_heading / runs;
      rows[k].rms_rad += e[k].rms_heading / runs;
    }
  }
  if (json) {
    std::string items;
    for (const Row& r : rows) {
      if (!items.empty()) items += ", ";
      items += fmt::format(
          "{{\"method\": \"{}\", \"max_translation_m\": {:.6g}, \"rms_translation_m\": {:.6g}, "
          "\"max_heading_rad\": {}, \"rms_heading_rad\": {}}}",
          r.name, r.max_m, r.rms_m, r.heading ? fmt::format("{:.6g}", r.max_rad) : "null",
          r.heading ? fmt::format("{:.6g}", r.rms_rad) : "null");
    }
    fmt::print("{{\"experiment\": \"sekimori-fig6\", \"runs\": {}, \"rows\": [{}]}}\n", runs,
               items);
    return 0;
  }
  fmt::print(
      "Sekimori & Miyazaki Section 4.3 / Fig. 6 on the simulator, speed (b): position-only\n"
      "camera fixes fused by the EKF; mean over {} runs (seeds {}..{}) of max and RMS errors.\n\n",
      runs, seed, seed + static_cast<std::uint64_t>(runs) - 1);
  fmt::print("{:<34} | {:>9} {:>9} | {:>9} {:>9}\n", "method", "max mm", "rms mm", "max deg",
             "rms deg");
  for (const Row& r : rows) {
    if (r.heading) {
      fmt::print("{:<34} | {:>9.1f} {:>9.1f} | {:>9.2f} {:>9.2f}\n", r.name, 1e3 * r.max_m,
                 1e3 * r.rms_m, kDeg * r.max_rad, kDeg * r.rms_rad);
    } else {
      fmt::print("{:<34} | {:>9.1f} {:>9.1f} | {:>9} {:>9}\n", r.name, 1e3 * r.max_m, 1e3 * r.rms_m,
                 "-", "-");
    }
  }
  return 0;
}

namespace {

const ExperimentRegistration kTable4{"sekimori-table4",
                                     "Sekimori & Miyazaki Table 4: max errors of wheels, 2 mice, "
                                     "voting, consensus, oracle (default 10 runs)",
                                     [](const ExperimentOptions& o) {
                                       return run_sekimori_table4(o.runs > 0 ? o.runs : 10, o.seed,
                                                                  o.json);
                                     }};

const ExperimentRegistration kFig6{"sekimori-fig6",
                                   "Sekimori & Miyazaki Fig. 6: camera, wheels, mice, and each "
                                   "fused by the EKF, speed (b) (default 5 runs)",
                                   [](const ExperimentOptions& o) {
                                     return run_sekimori_fig6(o.runs > 0 ? o.runs : 5, o.seed,
                                                              o.json);
                                   }};

}  // namespace

}  // namespace moa::cli
