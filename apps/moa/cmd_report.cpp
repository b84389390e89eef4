// moa report: one self-contained HTML page with plots of a run.
#include <fmt/core.h>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "moa/formats/error.hpp"
#include "moa/runs/odometry_run.hpp"
#include "moa/runs/output_path.hpp"
#include "moa/web/report.hpp"

namespace moa::cli {
namespace {

struct ReportArgs {
  std::string config;
  std::string log;
  std::string odometry;
  std::string truth;
  std::string calibration;
  std::string self_calibration;
  std::string diagnostics;
  std::string title;
  std::string out;
  std::size_t max_points = io::ReportOptions{}.max_points;
};

int run_report(const ReportArgs& args) {
  io::ReportInputs inputs;
  inputs.config = args.config;
  inputs.log = args.log;
  inputs.odometry = args.odometry;
  if (!args.truth.empty()) inputs.truth = args.truth;
  if (!args.calibration.empty()) inputs.calibration = args.calibration;
  if (!args.self_calibration.empty()) inputs.self_calibration = args.self_calibration;
  if (!args.diagnostics.empty()) inputs.diagnostics = args.diagnostics;
  inputs.title = args.title;
  std::vector<std::filesystem::path> read{inputs.config,
                                          inputs.odometry,
                                          inputs.truth.value_or(""),
                                          inputs.calibration.value_or(""),
                                          inputs.self_calibration.value_or(""),
                                          inputs.diagnostics.value_or("")};
  try {
    const auto log_files = io::resolve_log(inputs.log).files();
    read.insert(read.end(), log_files.begin(), log_files.end());
  } catch (const io::Error&) {
    // No log to overwrite: write_report says what is wrong with it.
  }
  io::refuse_output_onto_inputs(args.out, "--out", read);
  io::ReportOptions options;
  options.max_points = args.max_points;
  io::write_report(inputs, args.out, options);
  fmt::print("moa report: written to {}\n", args.out);
  return 0;
}

}  // namespace

void add_report(CLI::App& app, Action& action) {
  auto args = std::make_shared<ReportArgs>();
  auto* cmd = app.add_subcommand(
      "report",
      "One self-contained HTML page with plots of a run: trajectory, error against truth, "
      "sensors used and excluded, sensor speeds, calibrated mounts");
  cmd->add_option("--config", args->config, "Robot config (YAML) the odometry was made with")
      ->required();
  cmd->add_option("--log", args->log, "Log directory (mice.csv, optional camera.csv)")->required();
  cmd->add_option("--odometry", args->odometry, "odometry.csv written by moa odometry")->required();
  cmd->add_option("--truth", args->truth, "truth.csv (t,x,y,theta): adds the error plots");
  cmd->add_option("--calibration", args->calibration,
                  "Calibrated config (YAML, moa calibrate): nominal and calibrated mounts");
  cmd->add_option("--self-calibration", args->self_calibration,
                  "self-calibration.csv (moa odometry --self-calibration): each sensor's "
                  "estimated scale over time");
  cmd->add_option("--diagnostics", args->diagnostics,
                  "diagnostics.csv (moa odometry --diagnostics): with a gyro, where each "
                  "epoch's heading came from");
  cmd->add_option("--title", args->title, "Page title (default: after the log directory)");
  cmd->add_option("--max-points", args->max_points,
                  "Most points per plotted series; longer runs are binned in time")
      ->check(CLI::Range(std::size_t{2}, std::size_t{1000000}))
      ->capture_default_str();
  cmd->add_option("--out", args->out, "The HTML file to write")->required();
  cmd->callback([&action, args] { action = [args] { return run_report(*args); }; });
}

}  // namespace moa::cli
