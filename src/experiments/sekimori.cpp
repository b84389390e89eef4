// Sekimori & Miyazaki's experiments on the simulator: Table 4 (wheels, two
// mice, four mice voting; with moa's consensus and the oracle) and Fig. 6
// (camera fixes fused by the EKF). Every method is a `moa odometry` call on
// the log `moa simulate` writes (simulated_run.hpp).
#include <fmt/core.h>

#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "experiments_list.hpp"
#include "moa/experiments/simulated_run.hpp"
#include "moa/formats/json.hpp"
#include "moa/formats/log.hpp"

namespace moa::experiments {
namespace {

struct Table4Method {
  const char* name;
  EstimatorKind estimator;
  SensorMask sensors;
  /// Sekimori & Miyazaki Table 4 at speeds (a), (b): max error, mm and deg.
  std::optional<double> paper_mm[2];
  std::optional<double> paper_deg[2];
  /// The simulator's parameters were fitted to land on this row of the
  /// paper (docs/simulator.md): agreement there is by construction.
  bool fitted;
};

const Table4Method kTable4[] = {
    {"wheels", EstimatorKind::kWheels, ~SensorMask{0}, {191.499, 239.397}, {14.970, 19.264}, true},
    {"2 mice (m1, m3)", EstimatorKind::kLs, 0b0101u, {44.516, 627.237}, {4.918, 40.638}, false},
    {"4 mice, voting (Sekimori)",
     EstimatorKind::kSekimori,
     ~SensorMask{0},
     {38.011, 61.593},
     {4.607, 8.588},
     false},
    {"4 mice, consensus", EstimatorKind::kConsensus, ~SensorMask{0}, {}, {}, false},
    {"4 mice, oracle selection", EstimatorKind::kOracle, ~SensorMask{0}, {}, {}, false},
};
constexpr std::size_t kTable4Size = std::size(kTable4);

std::string figure(const std::optional<double>& x) {
  return x ? fmt::format("{:.1f}", *x) : std::string("-");
}

void report(const Options& o, const std::string& what, int run, int runs) {
  if (o.progress) o.progress(fmt::format("{}: run {}/{}", what, run, runs));
}

}  // namespace

Result sekimori_table4(const Options& options) {
  const int runs = options.runs > 0 ? options.runs : 10;
  const char* speeds[2] = {"a", "b"};
  // records[speed][method]: one per run
  std::vector<RunRecord> records[2][kTable4Size];
  ScratchDirectory scratch("moa-sekimori-table4");
  for (int s = 0; s < 2; ++s) {
    for (int k = 0; k < runs; ++k) {
      report(options, fmt::format("table 4, speed ({})", speeds[s]), k + 1, runs);
      const SimulatedRun run(std::string("sekimori-") + speeds[s],
                             options.seed + static_cast<std::uint64_t>(k), scratch.path());
      for (std::size_t m = 0; m < kTable4Size; ++m) {
        Method method{kTable4[m].name, {}};
        method.options.estimator = kTable4[m].estimator;
        method.options.sensors = kTable4[m].sensors;
        records[s][m].push_back(run.run(method));
      }
    }
  }
  const std::uint64_t last = options.seed + static_cast<std::uint64_t>(runs) - 1;

  io::JsonWriter json;
  json.begin_object().member("experiment", "sekimori-table4").member("runs", runs);
  json.member("first_seed", options.seed).member("last_seed", last);
  json.key("rows").begin_array();
  for (int s = 0; s < 2; ++s) {
    for (std::size_t m = 0; m < kTable4Size; ++m) {
      const auto& p = kTable4[m];
      json.begin_object().member("speed", speeds[s]).member("method", p.name);
      json.key("paper_max_translation_m");
      p.paper_mm[s] ? json.value(*p.paper_mm[s] / 1e3) : json.null();
      json.key("paper_max_heading_rad");
      p.paper_deg[s] ? json.value(to_radians(*p.paper_deg[s])) : json.null();
      json.member("simulator_fitted_to_paper", p.fitted);
      write_runs(json, records[s][m]);
      json.end_object();
    }
  }
  json.end_array().end_object();

  std::string text = fmt::format(
      "Sekimori & Miyazaki Table 4 on the simulator: mean over {} runs (seeds {}..{}) of the\n"
      "maximum error along the Table 3 path, +- the sd over the runs. Paper: their robot and "
      "floor.\n"
      "Rows marked 'fitted': the simulator's wheel slip was fitted to the paper's figures there\n"
      "(docs/simulator.md), so that agreement is by construction, not evidence.\n\n",
      runs, options.seed, last);
  text += fmt::format("{:<6} {:<27} | {:>16} {:>9} | {:>13} {:>9} |\n", "speed", "method",
                      "ours mm", "paper mm", "ours deg", "paper deg");
  MeanError mean[2][kTable4Size];
  for (int s = 0; s < 2; ++s) {
    for (std::size_t m = 0; m < kTable4Size; ++m) {
      const auto& p = kTable4[m];
      const MeanError e = mean_error(records[s][m]);
      mean[s][m] = e;
      text += fmt::format(
          "({})    {:<27} | {:>7.1f} +- {:>5.1f} {:>9} | {:>5.2f} +- {:>4.2f} {:>9} | {}\n",
          speeds[s], p.name, 1e3 * e.max_translation.mean, 1e3 * e.max_translation.sd,
          figure(p.paper_mm[s]), to_degrees(e.max_heading.mean), to_degrees(e.max_heading.sd),
          figure(p.paper_deg[s]), p.fitted ? "fitted" : "");
    }
  }
  // Conclusions, computed: how far the consensus and the voting are from the
  // oracle's lower bound, in units of the run-to-run spread.
  text += "\n";
  for (int s = 0; s < 2; ++s) {
    const double oracle = mean[s][4].max_translation.mean;
    for (const std::size_t m : {std::size_t{2}, std::size_t{3}}) {
      const double x = mean[s][m].max_translation.mean;
      text += fmt::format("({}) {}: {:.1f} mm, {:.2f}x the oracle's {:.1f} mm\n", speeds[s],
                          kTable4[m].name, 1e3 * x, oracle > 0 ? x / oracle : 0.0, 1e3 * oracle);
    }
  }
  text += "Each run's figures and the moa calls that reproduce them: --json.\n";
  return {text, json.str() + "\n"};
}

namespace {

/// The camera fixes alone against the truth at their capture times.
TrajectoryError camera_alone(const SimulatedRun& run) {
  std::vector<StampedPose> truth;
  for (const auto& r : io::read_all<io::TruthRow>(run.dir() / "truth.csv")) {
    truth.push_back({r.t, r.pose});
  }
  TrajectoryErrorAccumulator acc(truth);
  // camera.csv stamps a fix at its arrival; it shows the robot camera.latency earlier.
  for (const auto& f : io::read_all<io::CameraRow>(run.dir() / "camera.csv")) {
    const double captured = f.t - run.camera_latency();
    const auto at = interpolate(truth, captured);
    if (at) acc.add(captured, Pose2{f.position, at->theta});
  }
  return acc.result();
}

}  // namespace

Result sekimori_fig6(const Options& options) {
  const int runs = options.runs > 0 ? options.runs : 5;
  struct Row {
    const char* name;
    EstimatorKind estimator;
    bool fuse;
  };
  const Row rows[] = {{"wheel dead reckoning", EstimatorKind::kWheels, false},
                      {"wheels + camera (EKF)", EstimatorKind::kWheels, true},
                      {"mouse dead reckoning (consensus)", EstimatorKind::kConsensus, false},
                      {"mice + camera (EKF)", EstimatorKind::kConsensus, true}};
  constexpr std::size_t kRows = std::size(rows);
  std::vector<RunRecord> records[kRows];
  std::vector<RunRecord> camera;
  ScratchDirectory scratch("moa-sekimori-fig6");
  for (int k = 0; k < runs; ++k) {
    report(options, "fig. 6, speed (b)", k + 1, runs);
    const SimulatedRun run("sekimori-b", options.seed + static_cast<std::uint64_t>(k),
                           scratch.path());
    RunRecord cam;
    cam.seed = run.seed();
    cam.error = camera_alone(run);
    camera.push_back(cam);
    for (std::size_t m = 0; m < kRows; ++m) {
      Method method{rows[m].name, {}};
      method.options.estimator = rows[m].estimator;
      method.options.fuse_camera = rows[m].fuse;
      if (rows[m].fuse) method.options.camera_latency = run.camera_latency();
      records[m].push_back(run.run(method));
    }
  }
  const std::uint64_t last = options.seed + static_cast<std::uint64_t>(runs) - 1;
  io::JsonWriter json;
  json.begin_object().member("experiment", "sekimori-fig6").member("runs", runs);
  json.member("first_seed", options.seed).member("last_seed", last);
  json.key("rows").begin_array();
  json.begin_object().member("method", "camera alone");
  json.member("note", "camera.csv fixes against truth.csv at their capture times; position only");
  write_runs(json, camera);
  json.end_object();
  for (std::size_t m = 0; m < kRows; ++m) {
    json.begin_object().member("method", rows[m].name);
    write_runs(json, records[m]);
    json.end_object();
  }
  json.end_array().end_object();

  std::string text = fmt::format(
      "Sekimori & Miyazaki Section 4.3 / Fig. 6 on the simulator, speed (b): position-only\n"
      "camera fixes fused by the EKF; mean over {} runs (seeds {}..{}) of max and RMS errors.\n\n",
      runs, options.seed, last);
  text += fmt::format("{:<34} | {:>9} {:>9} | {:>9} {:>9}\n", "method", "max mm", "rms mm",
                      "max deg", "rms deg");
  const MeanError c = mean_error(camera);
  text += fmt::format("{:<34} | {:>9.1f} {:>9.1f} | {:>9} {:>9}\n", "camera alone",
                      1e3 * c.max_translation.mean, 1e3 * c.rms_translation.mean, "-", "-");
  MeanError e[kRows];
  for (std::size_t m = 0; m < kRows; ++m) {
    e[m] = mean_error(records[m]);
    text += fmt::format("{:<34} | {:>9.1f} {:>9.1f} | {:>9.2f} {:>9.2f}\n", rows[m].name,
                        1e3 * e[m].max_translation.mean, 1e3 * e[m].rms_translation.mean,
                        to_degrees(e[m].max_heading.mean), to_degrees(e[m].rms_heading.mean));
  }
  const double fused = e[3].rms_translation.mean;
  text += fmt::format(
      "\nMice + camera: RMS {:.1f} mm, {:.2f}x the camera alone and {:.2f}x the mice alone.\n",
      1e3 * fused, fused / c.rms_translation.mean, fused / e[2].rms_translation.mean);
  return {text, json.str() + "\n"};
}

}  // namespace moa::experiments
