#include "experiment_report.hpp"

#include <fmt/core.h>

#include <memory>
#include <random>
#include <string>
#include <vector>

#include "moa/io/error.hpp"
#include "moa/io/log.hpp"
#include "moa/io/report.hpp"
#include "moa/sim/log_writer.hpp"
#include "moa/sim/scenario.hpp"
#include "pipeline.hpp"

namespace moa::cli {
namespace {

namespace fs = std::filesystem;

// The run each experiment's page shows: the scenario the experiment is
// about and the estimator its headline result is for.
constexpr ExperimentReportRecipe kRecipes[] = {
    {"sekimori-table4", "sekimori-b", "consensus", false},
    {"sekimori-fig6", "sekimori-b", "consensus", true},
    {"kimlee-example", "kimlee", "ls", false},
    {"calibration-crb", "calibration", "consensus", false},
};

/// A fresh directory removed with everything in it when this goes.
class TemporaryDirectory {
 public:
  TemporaryDirectory() {
    std::random_device random;
    path_ = fs::temp_directory_path() / fmt::format("moa-experiment-report-{:08x}", random());
    fs::create_directories(path_);
  }
  ~TemporaryDirectory() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  TemporaryDirectory(const TemporaryDirectory&) = delete;
  TemporaryDirectory& operator=(const TemporaryDirectory&) = delete;
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

/// What `moa odometry --estimator E [--fuse-camera]` writes, into `out`.
void write_odometry(const fs::path& log, const ExperimentReportRecipe& recipe,
                    double camera_latency, const fs::path& out) {
  const fs::path config_path = log / "robot.yaml";
  const io::RobotConfig config = io::read_config(config_path);
  io::MiceReader reader(log, config);
  PipelineOptions options;
  options.estimator = recipe.estimator;
  options.fuse_camera = recipe.fuse_camera;
  options.camera_latency = camera_latency;
  std::unique_ptr<io::WheelsReader> wheels;
  if (fs::exists(log / "wheels.csv"))
    wheels = std::make_unique<io::WheelsReader>(log / "wheels.csv");
  std::unique_ptr<io::CameraReader> camera;
  if (recipe.fuse_camera) camera = std::make_unique<io::CameraReader>(log / "camera.csv");
  io::OdometryWriter writer(out, odometry_extra_columns(recipe.fuse_camera));
  std::vector<std::string> extra;
  Pipeline pipeline(config, config_path.string(), reader.start_time(), options, std::move(wheels),
                    std::move(camera), [&](const PipelineStep& step) {
                      odometry_extra_values(step, config, extra);
                      writer.write(step.sample.t, step.pose, step.estimate.estimate.twist, extra);
                    });
  const std::string where = (log / "mice.csv").string();
  while (const auto row = reader.next()) pipeline.push(*row, where);
  pipeline.finish();
  writer.commit();
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
  TemporaryDirectory dir;
  const fs::path log = dir.path() / "log";
  sim::write_log(scenario, seed, log);
  const fs::path odometry = dir.path() / "odometry.csv";
  write_odometry(log, recipe, scenario.camera.latency, odometry);
  io::ReportInputs inputs;
  inputs.config = log / "robot.yaml";
  inputs.log = log;
  inputs.odometry = odometry;
  inputs.truth = log / "truth.csv";
  inputs.title = fmt::format("moa experiment {}: scenario {}, seed {}, {} estimator{}",
                             recipe.experiment, recipe.scenario, seed, recipe.estimator,
                             recipe.fuse_camera ? " with camera fixes (EKF)" : "");
  inputs.note = fmt::format(
      "The run of `moa simulate --scenario {} --seed {}`, dead reckoning as `moa odometry "
      "--estimator {}{}`; its files were temporary.",
      recipe.scenario, seed, recipe.estimator,
      recipe.fuse_camera
          ? fmt::format(" --fuse-camera --camera-latency {}", scenario.camera.latency)
          : std::string{});
  io::write_report(inputs, out);
}

}  // namespace moa::cli
