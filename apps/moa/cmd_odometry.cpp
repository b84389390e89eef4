// moa odometry: dead reckoning from a log (docs/formats/cli.md): the
// library's pipeline over the log's files (io::write_odometry).
#include <fmt/core.h>
#include <unistd.h>

#include <chrono>
#include <memory>
#include <string>

#include "commands.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/error.hpp"
#include "moa/runs/odometry_run.hpp"
#include "moa/runs/output_path.hpp"
#include "odometry_options.hpp"

namespace moa::cli {
namespace {

struct OdometryArgs {
  std::string config;
  std::string log;
  std::string out;
  std::string faults;  ///< --faults FILE: the oracle's faults.csv, if not the log's
  OdometryFlags flags;
  bool quiet = false;
};

int run_odometry(const OdometryArgs& args) {
  const io::RobotConfig config = io::read_config(args.config);
  const OdometryOptions options = resolve_odometry_flags(args.flags, config, args.config);
  for (const auto& w : self_calibration_warnings(options)) {
    fmt::print(stderr, "moa odometry: warning: {}\n", w);
  }
  io::LogFiles log = io::resolve_log(args.log);
  if (!args.faults.empty()) log.faults = args.faults;
  if (options.self_calibration.enabled &&
      options.self_calibration.gauge == SelfCalibrationGauge::kWheels && !log.wheels) {
    throw io::Error(
        fmt::format("--self-calibration-gauge wheels: {} has no wheels.csv", log.dir.string()));
  }
  if (!args.faults.empty() && options.estimator != EstimatorKind::kOracle) {
    throw io::Error(fmt::format("--faults is read by --estimator oracle only (the estimator is {})",
                                to_name(options.estimator)));
  }
  io::refuse_output_onto_inputs(
      args.out, "--out",
      {args.config, log.mice, log.wheels.value_or(""), log.camera.value_or(""),
       log.truth.value_or(""), log.faults.value_or("")});
  if (!args.flags.self_calibration_out.empty()) {
    io::refuse_output_onto_inputs(
        args.flags.self_calibration_out, "--self-calibration",
        {args.config, log.mice, log.wheels.value_or(""), log.camera.value_or(""),
         log.truth.value_or(""), log.faults.value_or("")});
    io::refuse_output_onto_inputs(args.flags.self_calibration_out, "--self-calibration", {args.out},
                                  "the --out of this run");
  }
  if (!args.flags.diagnostics_out.empty()) {
    io::refuse_output_onto_inputs(
        args.flags.diagnostics_out, "--diagnostics",
        {args.config, log.mice, log.wheels.value_or(""), log.camera.value_or(""),
         log.truth.value_or(""), log.faults.value_or("")});
    io::refuse_output_onto_inputs(args.flags.diagnostics_out, "--diagnostics",
                                  {args.out, args.flags.self_calibration_out},
                                  "another output of this run");
  }

  const bool progress = !args.quiet && isatty(STDERR_FILENO);
  auto last_report = std::chrono::steady_clock::now();
  io::ProgressCallback on_progress;
  if (progress) {
    on_progress = [&](std::size_t rows, double t) {
      const auto now = std::chrono::steady_clock::now();
      if (now - last_report > std::chrono::seconds(1)) {
        fmt::print(stderr, "\rmoa odometry: {} rows, t = {:.1f} s", rows, t);
        last_report = now;
      }
    };
  }
  const io::OdometryRun run =
      io::write_odometry(config, args.config, log, options, args.out, on_progress,
                         args.flags.self_calibration_out, args.flags.diagnostics_out);
  if (progress) fmt::print(stderr, "\r\033[K");
  for (const auto& w : run.summary.warnings) {
    fmt::print(stderr, "moa odometry: warning: {}\n", w);
  }
  if (!args.quiet) {
    fmt::print(
        "moa odometry: {} rows, {} samples over {:.3f} s at {} Hz ({} estimator); odometry written "
        "to {}\n",
        run.rows, run.steps, run.t_end - run.t0, options.rate, to_name(options.estimator),
        args.out);
    fmt::print("{}", run.summary.text());
  }
  return 0;
}

}  // namespace

void add_odometry(CLI::App& app, Action& action) {
  auto args = std::make_shared<OdometryArgs>();
  auto* cmd = app.add_subcommand("odometry", "Dead reckoning from a log: odometry.csv out");
  cmd->add_option("--config", args->config, "Robot config v1 (YAML)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--log", args->log, "Log directory (log format v1) or its mice.csv")
      ->required()
      ->check(CLI::ExistingPath);
  cmd->add_option("--out", args->out, "Output odometry.csv (written whole or not at all)")
      ->required()
      ->check(output_file());
  add_odometry_flags(cmd, args->flags);
  cmd->add_option("--faults", args->faults,
                  "oracle: the simulator's faults.csv (default: the log's own)")
      ->check(CLI::ExistingFile);
  cmd->add_flag("--quiet", args->quiet, "Print nothing on success");
  cmd->callback([&action, args] { action = [args] { return run_odometry(*args); }; });
}

}  // namespace moa::cli
