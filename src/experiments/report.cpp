#include "moa/experiments/report.hpp"

#include <fmt/core.h>

#include <memory>
#include <random>
#include <string>
#include <vector>

#include "moa/experiments/simulated_run.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/log.hpp"
#include "moa/runs/odometry_run.hpp"
#include "moa/sim/log_writer.hpp"
#include "moa/sim/scenario.hpp"
#include "moa/web/report.hpp"

namespace moa::experiments {
namespace {

namespace fs = std::filesystem;

// The run each experiment's page shows: the scenario the experiment is
// about and the estimator its headline result is for.
constexpr ExperimentReportRecipe kRecipes[] = {
    {"sekimori-table4", "sekimori-b", "consensus", false},
    {"sekimori-fig6", "sekimori-b", "consensus", true},
    {"kimlee-example", "kimlee", "ls", false},
    {"calibration-crb", "calibration", "consensus", false},
    {"self-calibration", "selfcal-ramp", "consensus", false, true},
};

/// What `moa odometry --estimator E [--fuse-camera] [--self-calibration
/// CAL]` writes, into `out` (and `calibration`).
void write_odometry(const fs::path& log, const ExperimentReportRecipe& recipe,
                    double camera_latency, const fs::path& out, const fs::path& calibration) {
  const fs::path config_path = log / "robot.yaml";
  const io::RobotConfig config = io::read_config(config_path);
  OdometryOptions options;
  options.estimator = *from_name<EstimatorKind>(recipe.estimator);
  options.fuse_camera = recipe.fuse_camera;
  options.camera_latency = camera_latency;
  options.self_calibration.enabled = recipe.self_calibrate;
  io::write_odometry(config, config_path.string(), io::resolve_log(log), options, out, {},
                     recipe.self_calibrate ? calibration : fs::path{});
}

}  // namespace

const ExperimentReportRecipe* experiment_report_recipe(std::string_view experiment) {
  for (const auto& recipe : kRecipes) {
    if (experiment == recipe.experiment) return &recipe;
  }
  return nullptr;
}

void write_experiment_report(const ExperimentReportRecipe& recipe, std::uint64_t seed,
                             const fs::path& out) {
  const sim::Scenario scenario = sim::load_scenario(recipe.scenario);
  ScratchDirectory dir("moa-experiment-report");
  const fs::path log = dir.path() / "log";
  sim::write_log(scenario, seed, log);
  const fs::path odometry = dir.path() / "odometry.csv";
  const fs::path calibration = dir.path() / "self-calibration.csv";
  write_odometry(log, recipe, scenario.camera.latency, odometry, calibration);
  io::ReportInputs inputs;
  inputs.config = log / "robot.yaml";
  inputs.log = log;
  inputs.odometry = odometry;
  inputs.truth = log / "truth.csv";
  if (recipe.self_calibrate) inputs.self_calibration = calibration;
  inputs.title = fmt::format("moa experiment {}: scenario {}, seed {}, {} estimator{}{}",
                             recipe.experiment, recipe.scenario, seed, recipe.estimator,
                             recipe.fuse_camera ? " with camera fixes (EKF)" : "",
                             recipe.self_calibrate ? " with online self-calibration" : "");
  inputs.note = fmt::format(
      "The run of `moa simulate --scenario {} --seed {}`, dead reckoning as `moa odometry "
      "--estimator {}{}{}`; its files were temporary.",
      recipe.scenario, seed, recipe.estimator,
      recipe.fuse_camera
          ? fmt::format(" --fuse-camera --camera-latency {}", scenario.camera.latency)
          : std::string{},
      recipe.self_calibrate ? " --self-calibration self-calibration.csv" : "");
  io::write_report(inputs, out);
}

}  // namespace moa::experiments
