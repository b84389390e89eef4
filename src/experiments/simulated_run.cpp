#include "moa/experiments/simulated_run.hpp"

#include <fmt/core.h>

#include <cmath>
#include <random>
#include <stdexcept>

#include "moa/formats/self_calibration_csv.hpp"
#include "moa/runs/evaluate.hpp"
#include "moa/runs/odometry_run.hpp"
#include "moa/sim/log_writer.hpp"
#include "moa/sim/scenario.hpp"

namespace moa::experiments {
namespace fs = std::filesystem;

std::vector<std::string> odometry_flags(const OdometryOptions& o, const io::RobotConfig& config) {
  const OdometryOptions d;
  std::vector<std::string> flags;
  if (o.estimator != d.estimator) flags.insert(flags.end(), {"--estimator", to_name(o.estimator)});
  const SensorMask all = all_sensors(config.array.size());
  if ((o.sensors & all) != all) {
    std::string names;
    for (int i = 0; i < config.array.size(); ++i) {
      if (contains(o.sensors, i)) {
        names += (names.empty() ? "" : ",") + config.names[static_cast<std::size_t>(i)];
      }
    }
    flags.insert(flags.end(), {"--sensors", names});
  }
  if (!o.use_wheels) flags.emplace_back("--no-wheels");
  if (!o.use_imu) flags.emplace_back("--no-imu");
  if (o.fuse_camera) flags.emplace_back("--fuse-camera");
  if (o.camera_latency) {
    flags.insert(flags.end(), {"--camera-latency", fmt::format("{}", *o.camera_latency)});
  }
  if (o.rate != d.rate) flags.insert(flags.end(), {"--rate", fmt::format("{}", o.rate)});
  if (o.self_calibration.enabled) flags.emplace_back("--self-calibrate");
  // What the command line has no flag for must stay at its default.
  if (o.max_row_interval != d.max_row_interval || o.max_gap != d.max_gap || o.initial ||
      o.camera_sigma != d.camera_sigma || o.camera_heading_sigma != d.camera_heading_sigma ||
      o.sekimori.e_th != d.sekimori.e_th || o.sekimori.r_th != d.sekimori.r_th ||
      o.consensus.alpha != d.consensus.alpha ||
      o.self_calibration.scale_walk != d.self_calibration.scale_walk ||
      o.self_calibration.apply_alpha != d.self_calibration.apply_alpha ||
      o.self_calibration.runaway_scale != d.self_calibration.runaway_scale ||
      o.self_calibration.runaway_yaw != d.self_calibration.runaway_yaw ||
      o.self_calibration.runaway_alpha != d.self_calibration.runaway_alpha) {
    throw std::invalid_argument("odometry_flags: an option the experiments do not vary");
  }
  return flags;
}

ScratchDirectory::ScratchDirectory(const std::string& prefix) {
  std::random_device random;
  path_ = fs::temp_directory_path() / fmt::format("{}-{:08x}", prefix, random());
  fs::create_directories(path_);
}

ScratchDirectory::~ScratchDirectory() {
  std::error_code ignored;
  fs::remove_all(path_, ignored);
}

SimulatedRun::SimulatedRun(const std::string& scenario, std::uint64_t seed, const fs::path& scratch)
    : scenario_(scenario), seed_(seed), dir_(scratch / fmt::format("{}-seed{}", scenario, seed)) {
  const sim::Scenario s = sim::load_scenario(scenario);
  sim::write_log(s, seed, dir_);
  config_ = io::read_config(dir_ / "robot.yaml");
  camera_latency_ = s.camera.latency;
}

SimulatedRun::~SimulatedRun() {
  std::error_code ignored;
  fs::remove_all(dir_, ignored);
}

Method method_of(std::string name, EstimatorKind estimator, bool self_calibrate) {
  Method method{std::move(name), {}};
  method.options.estimator = estimator;
  method.options.self_calibration.enabled = self_calibrate;
  return method;
}

RunRecord SimulatedRun::run(const Method& method, bool keep_calibration) const {
  const fs::path config = dir_ / "robot.yaml";
  const int k = runs_++;
  const fs::path odometry = dir_ / fmt::format("odometry-{}.csv", k);
  const bool calibration = keep_calibration && method.options.self_calibration.enabled;
  const fs::path estimates =
      calibration ? dir_ / fmt::format("self-calibration-{}.csv", k) : fs::path{};
  io::write_odometry(config_, config.string(), io::resolve_log(dir_), method.options, odometry, {},
                     estimates);
  RunRecord r;
  r.seed = seed_;
  r.error = io::evaluate_files(dir_ / "truth.csv", odometry);
  fs::remove(odometry);
  if (calibration) {
    r.calibration = io::read_self_calibration_csv(estimates);
    fs::remove(estimates);
  }
  std::string flags;
  for (const auto& f : odometry_flags(method.options, config_)) flags += " " + f;
  if (calibration) flags += " --self-calibration $OUT/self-calibration.csv";
  r.reproduce = {
      fmt::format("moa simulate --scenario {} --seed {} --out $OUT", scenario_, seed_),
      fmt::format("moa odometry --config $OUT/robot.yaml --log $OUT{} --out $OUT/odometry.csv",
                  flags),
      "moa evaluate --truth $OUT/truth.csv --odometry $OUT/odometry.csv --json"};
  return r;
}

Spread spread(const std::vector<double>& values) {
  Spread s;
  if (values.empty()) return s;
  for (const double v : values) s.mean += v;
  s.mean /= static_cast<double>(values.size());
  if (values.size() > 1) {
    double ss = 0.0;
    for (const double v : values) ss += (v - s.mean) * (v - s.mean);
    s.sd = std::sqrt(ss / static_cast<double>(values.size() - 1));
  }
  return s;
}

}  // namespace moa::experiments

#include "moa/formats/json.hpp"

namespace moa::experiments {

MeanError mean_error(const std::vector<RunRecord>& runs) {
  std::vector<double> a, b, c, d, f;
  for (const auto& r : runs) {
    a.push_back(r.error.max_translation);
    b.push_back(r.error.rms_translation);
    c.push_back(r.error.max_heading);
    d.push_back(r.error.rms_heading);
    f.push_back(r.error.final_translation);
  }
  return {spread(a), spread(b), spread(c), spread(d), spread(f)};
}

void write_runs(io::JsonWriter& json, const std::vector<RunRecord>& runs) {
  const MeanError m = mean_error(runs);
  json.member("max_translation_m", m.max_translation.mean)
      .member("rms_translation_m", m.rms_translation.mean)
      .member("max_heading_rad", m.max_heading.mean)
      .member("rms_heading_rad", m.rms_heading.mean)
      .member("final_translation_m", m.final_translation.mean)
      .member("sd_max_translation_m", m.max_translation.sd)
      .member("sd_max_heading_rad", m.max_heading.sd);
  json.key("runs").begin_array();
  for (const auto& r : runs) {
    json.begin_object().member("seed", r.seed);
    for_each_member(r.error,
                    [&json](const char* name, const auto& value) { json.member(name, value); });
    json.key("reproduce").begin_array();
    for (const auto& call : r.reproduce) json.value(call);
    json.end_array().end_object();
  }
  json.end_array();
}

}  // namespace moa::experiments
