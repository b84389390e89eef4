// moa odometry: dead reckoning from a log (spec/cli.md).
//
// Data path: MiceReader (rows) -> Synchroniser (epochs) -> estimator
// (twist + covariance) -> DeadReckoner (exact SE(2) step) -> odometry.csv.
// Everything is streamed: memory does not grow with the log's length.
#include <fmt/core.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "commands.hpp"
#include "moa/estimate.hpp"
#include "moa/io/config.hpp"
#include "moa/io/error.hpp"
#include "moa/io/log.hpp"
#include "moa/synchronise.hpp"

namespace moa::cli {
namespace {

struct OdometryArgs {
  std::string config;
  std::string log;
  std::string estimator = "ls";
  std::string out;
  double rate = 100.0;
  double max_row_interval = 0.05;
  std::vector<double> initial_pose{0.0, 0.0, 0.0};
  bool quiet = false;
};

std::string fmt_sd(double variance) {
  return fmt::format("{:.6g}", std::sqrt(std::max(variance, 0.0)));
}

int run_odometry(const OdometryArgs& args) {
  if (args.estimator != "ls") {
    throw io::Error(fmt::format(
        "--estimator {}: not available in this version of moa (available: ls)", args.estimator));
  }
  const io::RobotConfig config = io::read_config(args.config);
  io::MiceReader reader(args.log, config);

  const double period = 1.0 / args.rate;
  const auto built = LsEstimator::create(config.array, all_sensors(config.array.size()), period);
  if (const auto* error = std::get_if<GeometryError>(&built)) {
    throw io::Error(fmt::format("{}: {}", args.config, describe(*error)));
  }
  const auto& estimator = std::get<LsEstimator>(built);

  const double t0 = reader.start_time();
  Synchroniser sync(config.array.size(), t0, {period, args.max_row_interval});
  DeadReckoner reckoner(Pose2{{args.initial_pose[0], args.initial_pose[1]}, args.initial_pose[2]});
  io::OdometryWriter writer(args.out, {"sd_vx", "sd_vy", "sd_omega"});

  std::vector<std::string> extra(3);
  std::size_t samples = 0;
  const auto sink = [&](const ArraySample& sample) {
    const auto estimate = estimator.estimate(sample);
    if (!estimate) {
      throw io::Error(
          fmt::format("{}: sample at t = {} s has no valid interval", args.log, sample.t));
    }
    const Pose2& pose = reckoner.step(estimate->twist, sample.dt);
    for (int k = 0; k < 3; ++k)
      extra[static_cast<std::size_t>(k)] = fmt_sd(estimate->covariance(k, k));
    writer.write(sample.t, pose, estimate->twist, extra);
    ++samples;
  };

  const bool progress = !args.quiet && isatty(STDERR_FILENO);
  auto last_report = std::chrono::steady_clock::now();
  std::size_t rows = 0;
  double t_last = t0;
  while (const auto row = reader.next()) {
    if (const auto error = sync.push(*row, sink)) {
      throw io::Error(
          fmt::format("{}: row {} (t = {} s): {}", args.log, rows + 1, row->t, describe(*error)));
    }
    t_last = row->t;
    ++rows;
    if (progress && (rows & 0xfff) == 0) {
      const auto now = std::chrono::steady_clock::now();
      if (now - last_report > std::chrono::seconds(1)) {
        fmt::print(stderr, "\rmoa odometry: {} rows, t = {:.1f} s", rows, t_last - t0);
        last_report = now;
      }
    }
  }
  sync.finish(t_last, sink);
  writer.commit();
  if (progress) fmt::print(stderr, "\r");
  if (!args.quiet) {
    fmt::print("moa odometry: {} rows, {} samples over {:.3f} s at {} Hz; odometry written to {}\n",
               rows, samples, t_last - t0, args.rate, args.out);
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
  cmd->add_option("--estimator", args->estimator, "Twist estimator")
      ->check(CLI::IsMember({"ls", "sekimori", "consensus"}))
      ->capture_default_str();
  cmd->add_option("--out", args->out, "Output odometry.csv (written whole or not at all)")
      ->required();
  cmd->add_option("--rate", args->rate, "Epoch rate of the synchroniser, Hz")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--max-row-interval", args->max_row_interval,
                  "Longest interval one mice.csv row may cover, s (a sensor silent for longer "
                  "was still before its row)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--initial-pose", args->initial_pose,
                  "Initial pose X,Y,THETA in the world frame (m, m, rad)")
      ->expected(3)
      ->delimiter(',');
  cmd->add_flag("--quiet", args->quiet, "Print nothing on success");
  cmd->callback([&action, args] { action = [args] { return run_odometry(*args); }; });
}

}  // namespace moa::cli
