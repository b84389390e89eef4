// `moa experiment gyro` (issue #29): the heading error of the mouse array
// alone, of the gyro alone and of the two fused, on three robots that share
// one path (built-in scenarios gyro-compact and gyro-papers: 2 s at rest,
// then straight runs, arcs, a sideways run and turns in place both ways,
// 33 s; no common-mode dropouts, see gyro-bump for those) and one z gyro
// (2 % off in scale, biased 0.01 rad/s, bias walk, 5 ms late; robot.yaml
// knows its noise, full scale and latency, not its scale or bias):
//  1. compact array: four sensors 1.5 cm from the centre (gyro-compact);
//  2. the papers' layout: four sensors 0.1 m from the centre (gyro-papers,
//     sekimori-a's array);
//  3. one sensor and the gyro: gyro-compact's log cut to its sensor m1
//     (robot.yaml and mice.csv; imu.csv, wheels.csv and truth.csv kept).
//     Where the estimator refuses a one-sensor config the row says so.
//
// Methods (the pipeline of `moa odometry`, simulated_run.hpp):
//  - array alone: `moa odometry --no-imu` (imu.csv ignored);
//  - fused: `moa odometry` (the consensus with imu.csv);
//  - gyro alone: the heading integrated from imu.csv alone with what
//    robot.yaml believes (imu: scale k, bias c, latency L): a row j ending
//    at t_j (its interval [t_{j-1}, t_j], the first row only opens) gives
//      omega_j = (g_j - c) / k   (rad/s),
//      theta(t_j - L) = theta(t_{j-1} - L) + omega_j (t_j - t_{j-1}),
//    from the truth's heading at t_0 - L (the start pose every estimate
//    shares); its error |wrap(theta - theta_truth)| at each row's t_j - L,
//    truth interpolated as `moa evaluate` does (analysis/evaluate.hpp);
//  - gyro alone, bias at rest: the same with c the mean reading of the rows
//    whose interval ends within the initial rest (the scenario's first
//    segment, 2 s at rest: a robot knows when it has not been told to move
//    yet), k still the config's.
// Heading errors max and RMS over the run (deg in the text, rad in the
// JSON), translation error max (mm; the gyro alone has no translation).
#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "experiments_list.hpp"
#include "moa/analysis/evaluate.hpp"
#include "moa/experiments/simulated_run.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/json.hpp"
#include "moa/formats/log.hpp"
#include "moa/runs/evaluate.hpp"
#include "moa/runs/odometry_run.hpp"

namespace moa::experiments {
namespace {

namespace fs = std::filesystem;

struct GyroCase {
  const char* name;
  const char* scenario;
  const char* only;  ///< nullptr: every sensor; else the log cut to this sensor
  double rest;       ///< s at rest at the start (the scenario's first segment)
  const char* describes;
};
const GyroCase kCases[] = {
    {"compact array", "gyro-compact", nullptr, 2.0,
     "four sensors 1.5 cm from the centre (one sensor unit)"},
    {"papers' layout", "gyro-papers", nullptr, 2.0,
     "four sensors 0.1 m from the centre (sekimori-a's array)"},
    {"one sensor + gyro", "gyro-compact", "m1", 2.0,
     "gyro-compact's log cut to m1 (1.5 cm from the centre); no rotation is measured but the "
     "gyro's, so its scale is robot.yaml's (the 2 % error stays)"},
};
constexpr std::size_t kCaseCount = std::size(kCases);

// The methods, in the order of the rows and columns.
enum MethodIndex : std::size_t { kArray, kGyro, kGyroRest, kFused, kMethodCount };
const char* const kMethodNames[kMethodCount] = {"array alone", "gyro alone",
                                                "gyro alone, bias at rest", "fused"};

/// One method on one run: the figures, or why the estimator refused.
struct Figures {
  std::uint64_t seed = 0;
  std::string refused;  ///< the estimator's error, empty when it ran
  TrajectoryError error;
  double bias = 0.0;  ///< rad/s, the bias the gyro-alone heading used
  std::vector<std::string> reproduce;
};

/// The gyro-alone heading's errors (formula at the top of the file): max,
/// RMS and final heading error; translation fields left 0.
TrajectoryError gyro_alone(const std::vector<io::ImuRow>& imu, std::span<const StampedPose> truth,
                           const GyroOptions& believed, double bias) {
  TrajectoryError e;
  if (imu.size() < 2) return e;
  const double latency = believed.latency;
  const auto start = interpolate(truth, imu.front().t - latency);
  double theta = start ? start->theta : 0.0;
  double sum_sq = 0.0;
  for (std::size_t j = 1; j < imu.size(); ++j) {
    theta += (imu[j].gz - bias) / believed.scale * (imu[j].t - imu[j - 1].t);
    const auto true_pose = interpolate(truth, imu[j].t - latency);
    if (!true_pose) continue;
    const double err = std::abs(std::remainder(theta - true_pose->theta, 2.0 * std::numbers::pi));
    e.max_heading = std::max(e.max_heading, err);
    e.final_heading = err;
    sum_sq += err * err;
    ++e.samples;
  }
  if (e.samples > 0) e.rms_heading = std::sqrt(sum_sq / static_cast<double>(e.samples));
  return e;
}

/// The mean reading (rad/s) of the rows whose interval ends within the
/// first `rest` s of truth.csv (its first t), latency taken off.
double rest_bias(const std::vector<io::ImuRow>& imu, double t0, double rest, double latency) {
  double sum = 0.0;
  int n = 0;
  for (std::size_t j = 1; j < imu.size() && imu[j].t - latency <= t0 + rest; ++j) {
    sum += imu[j].gz;
    ++n;
  }
  return n > 0 ? sum / n : 0.0;
}

/// gyro-compact's log cut to sensor `name`, in dir/<name>: robot.yaml with
/// that sensor only (the imu block kept), mice.csv's rows of that sensor,
/// imu.csv, wheels.csv and truth.csv copied. Returns the new directory.
fs::path cut_to_sensor(const SimulatedRun& run, const std::string& name) {
  const fs::path out = run.dir() / name;
  fs::create_directories(out);
  io::RobotConfig config = run.config();
  const auto index = config.index_of(name);
  if (!index) throw std::invalid_argument("gyro experiment: no sensor " + name);
  const SensorMount mount = config.array[*index];
  config.array = SensorArray(std::span<const SensorMount>(&mount, 1));
  config.names = {name};
  io::write_config(config, out / "robot.yaml");
  std::ifstream in(run.dir() / "mice.csv");
  std::ofstream mice(out / "mice.csv");
  // Comments and the header line kept, then the rows whose sensor field is `name`.
  std::string line;
  bool header = true;
  const std::string field = "," + name + ",";
  while (std::getline(in, line)) {
    const bool comment = line.starts_with('#');
    if (comment || header || line.find(field) != std::string::npos) mice << line << '\n';
    if (!comment) header = false;
  }
  for (const char* file : {"imu.csv", "wheels.csv", "truth.csv"}) {
    if (fs::exists(run.dir() / file)) fs::copy_file(run.dir() / file, out / file);
  }
  return out;
}

/// `moa odometry` (with `use_imu`) on the cut log in `dir`, then `moa
/// evaluate`; a refusal (io::Error from the pipeline) is kept as text.
Figures run_cut(const SimulatedRun& run, const fs::path& dir, bool use_imu) {
  Figures f;
  f.seed = run.seed();
  const fs::path odometry = dir / (use_imu ? "odometry-fused.csv" : "odometry-array.csv");
  OdometryOptions options;
  options.use_imu = use_imu;
  const std::string flags = use_imu ? "" : " --no-imu";
  const std::string cut = fmt::format("$OUT/{}", dir.filename().string());  // as in reproduce
  f.reproduce = {
      fmt::format("moa simulate --scenario {} --seed {} --out $OUT", run.scenario(), run.seed()),
      fmt::format("# {}: robot.yaml and mice.csv of $OUT cut to sensor {}; imu.csv, wheels.csv, "
                  "truth.csv copied",
                  cut, dir.filename().string()),
      fmt::format("moa odometry --config {0}/robot.yaml --log {0}{1} --out {0}/odometry.csv", cut,
                  flags),
      fmt::format("moa evaluate --truth {0}/truth.csv --odometry {0}/odometry.csv --json", cut)};
  try {
    const fs::path config = dir / "robot.yaml";
    io::write_odometry(io::read_config(config), config.string(), io::resolve_log(dir), options,
                       odometry);
    f.error = io::evaluate_files(dir / "truth.csv", odometry);
  } catch (const std::exception& e) {
    // The scratch directory named as in the reproducing calls.
    f.refused = e.what();
    for (std::size_t at; (at = f.refused.find(dir.string())) != std::string::npos;) {
      f.refused.replace(at, dir.string().size(), cut);
    }
  }
  std::error_code ignored;
  fs::remove(odometry, ignored);
  return f;
}

Figures from_record(const RunRecord& r) {
  Figures f;
  f.seed = r.seed;
  f.error = r.error;
  f.reproduce = r.reproduce;
  return f;
}

/// The gyro-alone figures of `dir`'s imu.csv against its truth.csv.
void gyro_figures(const fs::path& dir, const GyroOptions& believed, double rest, Figures& config,
                  Figures& at_rest) {
  std::vector<StampedPose> truth;
  for (const auto& row : io::read_all<io::TruthRow>(dir / "truth.csv")) {
    truth.push_back({row.t, row.pose});
  }
  const auto imu = io::read_all<io::ImuRow>(dir / "imu.csv");
  config.bias = believed.bias;
  config.error = gyro_alone(imu, truth, believed, config.bias);
  at_rest.bias = rest_bias(imu, truth.front().t, rest, believed.latency);
  at_rest.error = gyro_alone(imu, truth, believed, at_rest.bias);
}

/// Whether every run of the row ran; else the first refusal.
std::string refusal(const std::vector<Figures>& runs) {
  for (const auto& r : runs) {
    if (!r.refused.empty()) return r.refused;
  }
  return {};
}

struct Mean {
  double max_heading = 0.0, rms_heading = 0.0, max_translation = 0.0;  ///< rad, rad, m
};
Mean mean_of(const std::vector<Figures>& runs) {
  Mean m;
  const double n = static_cast<double>(runs.size());
  for (const auto& r : runs) {
    m.max_heading += r.error.max_heading / n;
    m.rms_heading += r.error.rms_heading / n;
    m.max_translation += r.error.max_translation / n;
  }
  return m;
}

/// Of the seeds both ran: on how many `a`'s figure is below `b`'s by more
/// than 1 % of b's, and on how many the two are within 1 % (a tie).
struct Wins {
  int won = 0, tied = 0, of = 0;
};
Wins wins(const std::vector<Figures>& a, const std::vector<Figures>& b,
          double TrajectoryError::*figure) {
  Wins w;
  for (std::size_t k = 0; k < a.size() && k < b.size(); ++k) {
    if (!a[k].refused.empty() || !b[k].refused.empty()) continue;
    ++w.of;
    const double x = a[k].error.*figure, y = b[k].error.*figure;
    if (std::abs(x - y) <= 0.01 * std::abs(y)) {
      ++w.tied;
    } else if (x < y) {
      ++w.won;
    }
  }
  return w;
}

std::string wins_text(const Wins& w) {
  return w.tied == 0 ? fmt::format("on {} of {} seeds", w.won, w.of)
                     : fmt::format("on {} of {} seeds (within 1 % on {})", w.won, w.of, w.tied);
}

void write_row(io::JsonWriter& json, const std::vector<Figures>& runs, bool translation) {
  const std::string refused = refusal(runs);
  if (!refused.empty()) {
    json.member("refused", refused);
    return;
  }
  const Mean m = mean_of(runs);
  json.member("max_heading_rad", m.max_heading).member("rms_heading_rad", m.rms_heading);
  if (translation) json.member("max_translation_m", m.max_translation);
  json.key("runs").begin_array();
  for (const auto& r : runs) {
    json.begin_object().member("seed", r.seed);
    if (translation) {
      for_each_member(r.error,
                      [&json](const char* name, const auto& value) { json.member(name, value); });
      json.key("reproduce").begin_array();
      for (const auto& call : r.reproduce) json.value(call);
      json.end_array();
    } else {
      json.member("samples", r.error.samples)
          .member("max_heading_rad", r.error.max_heading)
          .member("rms_heading_rad", r.error.rms_heading)
          .member("final_heading_rad", r.error.final_heading)
          .member("bias_rad_s", r.bias);
    }
    json.end_object();
  }
  json.end_array();
}

std::string heading_cell(const std::vector<Figures>& runs) {
  if (!refusal(runs).empty()) return fmt::format("{:>15}", "refused");
  const Mean m = mean_of(runs);
  return fmt::format("{:>7.2f} {:>7.2f}", to_degrees(m.max_heading), to_degrees(m.rms_heading));
}

std::string translation_cell(const std::vector<Figures>& runs) {
  if (!refusal(runs).empty()) return fmt::format("{:>8}", "refused");
  return fmt::format("{:>8.1f}", 1e3 * mean_of(runs).max_translation);
}

}  // namespace

Result gyro(const Options& options) {
  const int runs = options.runs > 0 ? options.runs : 5;
  std::vector<Figures> figures[kCaseCount][kMethodCount];
  std::vector<double> true_bias;  ///< rad/s, robot.true.yaml's, per seed of the first case
  ScratchDirectory scratch("moa-gyro");
  Method array = method_of("array alone", EstimatorKind::kConsensus);
  array.options.use_imu = false;
  const Method fused = method_of("fused", EstimatorKind::kConsensus);
  for (int k = 0; k < runs; ++k) {
    const std::uint64_t seed = options.seed + static_cast<std::uint64_t>(k);
    // One simulation per scenario and seed; the one-sensor case cuts gyro-compact's.
    for (std::size_t c = 0; c < kCaseCount; ++c) {
      if (kCases[c].only) continue;
      if (options.progress) {
        options.progress(fmt::format("{}: run {}/{}", kCases[c].scenario, k + 1, runs));
      }
      const SimulatedRun run(kCases[c].scenario, seed, scratch.path());
      const GyroOptions believed = run.config().imu.value_or(GyroOptions{});
      if (c == 0) {
        true_bias.push_back(
            io::read_config(run.dir() / "robot.true.yaml").imu.value_or(GyroOptions{}).bias);
      }
      for (std::size_t d = 0; d < kCaseCount; ++d) {
        if (kCases[d].scenario != std::string_view(kCases[c].scenario)) continue;
        if (!kCases[d].only) {
          figures[d][kArray].push_back(from_record(run.run(array)));
          figures[d][kFused].push_back(from_record(run.run(fused)));
          Figures g, r;
          g.seed = r.seed = seed;
          gyro_figures(run.dir(), believed, kCases[d].rest, g, r);
          figures[d][kGyro].push_back(g);
          figures[d][kGyroRest].push_back(r);
        } else {
          const fs::path dir = cut_to_sensor(run, kCases[d].only);
          figures[d][kArray].push_back(run_cut(run, dir, false));
          figures[d][kFused].push_back(run_cut(run, dir, true));
          Figures g, r;
          g.seed = r.seed = seed;
          gyro_figures(dir, believed, kCases[d].rest, g, r);
          figures[d][kGyro].push_back(g);
          figures[d][kGyroRest].push_back(r);
        }
      }
    }
  }
  const std::uint64_t last = options.seed + static_cast<std::uint64_t>(runs) - 1;

  io::JsonWriter json;
  json.begin_object().member("experiment", "gyro").member("runs", runs);
  json.member("first_seed", options.seed).member("last_seed", last);
  json.key("rows").begin_array();
  for (std::size_t c = 0; c < kCaseCount; ++c) {
    for (std::size_t m = 0; m < kMethodCount; ++m) {
      json.begin_object()
          .member("case", kCases[c].name)
          .member("scenario", kCases[c].scenario)
          .member("sensors", kCases[c].only ? kCases[c].only : "all")
          .member("rest_s", kCases[c].rest)
          .member("method", kMethodNames[m]);
      write_row(json, figures[c][m], m == kArray || m == kFused);
      json.end_object();
    }
  }
  json.end_array().end_object();

  std::string text = fmt::format(
      "Heading of the mouse array alone (moa odometry --no-imu), of the gyro alone (imu.csv\n"
      "integrated with robot.yaml's scale and bias, or with the bias measured over the first\n"
      "2 s at rest) and fused (moa odometry), 33 s runs with turns both ways; a gyro 2 % off in\n"
      "scale, biased 0.01 rad/s. Mean over {} runs (seeds {}..{}) of each run's max and RMS\n"
      "heading error (deg) and max translation error (mm).\n\n",
      runs, options.seed, last);
  text += fmt::format("{:<18} | {:>15} | {:>15} | {:>15} | {:>15} | {:>8} | {:>8}\n", "",
                      "array alone", "gyro alone", "gyro, rest bias", "fused", "array", "fused");
  text +=
      fmt::format("{:<18} | {:>15} | {:>15} | {:>15} | {:>15} | {:>8} | {:>8}\n", "case",
                  "max/rms deg", "max/rms deg", "max/rms deg", "max/rms deg", "max mm", "max mm");
  for (std::size_t c = 0; c < kCaseCount; ++c) {
    text += fmt::format("{:<18} | {} | {} | {} | {} | {} | {}\n", kCases[c].name,
                        heading_cell(figures[c][kArray]), heading_cell(figures[c][kGyro]),
                        heading_cell(figures[c][kGyroRest]), heading_cell(figures[c][kFused]),
                        translation_cell(figures[c][kArray]), translation_cell(figures[c][kFused]));
  }
  // Conclusions, computed: per case, on how many seeds the fused heading's
  // RMS error and max translation error are below each other method's; and
  // the refusals.
  text += "\n";
  for (std::size_t c = 0; c < kCaseCount; ++c) {
    text += fmt::format("{}:\n", kCases[c].name);
    bool any = false;
    for (const std::size_t m : {kArray, kGyro, kGyroRest}) {
      const Wins w = wins(figures[c][kFused], figures[c][m], &TrajectoryError::rms_heading);
      if (w.of == 0) continue;
      text += fmt::format("  fused: RMS heading error below that of the {} {}\n", kMethodNames[m],
                          wins_text(w));
      any = true;
    }
    const Wins w = wins(figures[c][kFused], figures[c][kArray], &TrajectoryError::max_translation);
    if (w.of > 0) {
      text += fmt::format("  fused: max translation error below that of the array alone {}\n",
                          wins_text(w));
    }
    if (!any) text += "  no fused heading to compare\n";
    for (const std::size_t m : {kArray, kFused}) {
      const std::string refused = refusal(figures[c][m]);
      if (!refused.empty()) text += fmt::format("  {}: refused: {}\n", kMethodNames[m], refused);
    }
  }
  // The bias measured at rest against robot.yaml's and the true one
  // (robot.true.yaml, at t = 0), on the first case.
  {
    double measured = 0.0, real = 0.0;
    for (const auto& r : figures[0][kGyroRest]) measured += r.bias / runs;
    for (const double b : true_bias) real += b / runs;
    text += fmt::format(
        "bias measured over the initial rest: {:.4f} rad/s on average over the seeds (true "
        "{:.4f}, robot.yaml {:.4f})\n",
        measured, real, figures[0][kGyro].front().bias);
  }
  text +=
      "The gyro-alone columns are the same in every case: one path, one gyro, the same seeds.\n";
  text += "\n";
  for (const auto& c : kCases)
    text += fmt::format("{}: {}, scenario {}\n", c.name, c.describes, c.scenario);
  text += "Each run's figures and the moa calls that reproduce them: --json.\n";
  return {text, json.str() + "\n"};
}

}  // namespace moa::experiments
