// moa odometry: dead reckoning from a log (spec/cli.md).
#include <fmt/core.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "moa/io/config.hpp"
#include "moa/io/error.hpp"
#include "moa/io/log.hpp"
#include "pipeline.hpp"

namespace moa::cli {
namespace {

struct OdometryArgs {
  std::string config;
  std::string log;
  std::string out;
  PipelineOptions pipeline;
  std::vector<double> initial_pose;
  bool no_wheels = false;
  bool quiet = false;
};

int run_odometry(OdometryArgs args) {
  namespace fs = std::filesystem;
  const io::RobotConfig config = io::read_config(args.config);
  io::MiceReader reader(args.log, config);
  const fs::path log_dir =
      fs::is_directory(args.log) ? fs::path(args.log) : fs::path(args.log).parent_path();
  std::unique_ptr<io::WheelsReader> wheels;
  if (!args.no_wheels && fs::exists(log_dir / "wheels.csv")) {
    wheels = std::make_unique<io::WheelsReader>(log_dir / "wheels.csv");
  }
  if (args.initial_pose.size() == 3) {
    args.pipeline.initial =
        Pose2{{args.initial_pose[0], args.initial_pose[1]}, args.initial_pose[2]};
  }
  std::unique_ptr<io::CameraReader> camera;
  if (args.pipeline.fuse_camera) {
    if (!fs::exists(log_dir / "camera.csv")) {
      throw io::Error(fmt::format("{}: --fuse-camera needs camera.csv in the log",
                                  (log_dir / "camera.csv").string()));
    }
    camera = std::make_unique<io::CameraReader>(log_dir / "camera.csv");
  }

  io::OdometryWriter writer(args.out, odometry_extra_columns(args.pipeline.fuse_camera));
  std::vector<std::string> extra;
  const double t0 = reader.start_time();
  Pipeline pipeline(config, args.config, t0, args.pipeline, std::move(wheels), std::move(camera),
                    [&](const PipelineStep& step) {
                      odometry_extra_values(step, config, extra);
                      writer.write(step.sample.t, step.pose, step.estimate.estimate.twist, extra);
                    });

  const bool progress = !args.quiet && isatty(STDERR_FILENO);
  auto last_report = std::chrono::steady_clock::now();
  const std::string where = (log_dir / "mice.csv").string();
  std::size_t rows = 0;
  while (const auto row = reader.next()) {
    pipeline.push(*row, where);
    ++rows;
    if (progress && (rows & 0xfff) == 0) {
      const auto now = std::chrono::steady_clock::now();
      if (now - last_report > std::chrono::seconds(1)) {
        fmt::print(stderr, "\rmoa odometry: {} rows, t = {:.1f} s", rows,
                   pipeline.last_time() - t0);
        last_report = now;
      }
    }
  }
  pipeline.finish();
  writer.commit();
  if (progress) fmt::print(stderr, "\r\033[K");
  if (!args.quiet) {
    fmt::print(
        "moa odometry: {} rows, {} samples over {:.3f} s at {} Hz ({} estimator); odometry written "
        "to {}\n",
        rows, pipeline.samples(), pipeline.last_time() - t0, args.pipeline.rate,
        args.pipeline.estimator, args.out);
    if (args.pipeline.fuse_camera) {
      const FixCounts& f = pipeline.fixes();
      fmt::print(
          "camera fixes: {} applied, {} rejected as outliers, {} older than the filter's history, "
          "{} invalid\n",
          f.applied, f.rejected, f.too_old, f.invalid);
    }
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
  cmd->add_option("--estimator", args->pipeline.estimator,
                  "Twist estimator: ls (all sensors, least squares), sekimori (pairwise voting, "
                  "Sekimori & Miyazaki), consensus (largest consistent set)")
      ->check(CLI::IsMember({"ls", "sekimori", "consensus"}))
      ->capture_default_str();
  cmd->add_option("--e-th", args->pipeline.sekimori.e_th,
                  "sekimori: E_th of eq. (7), m^2, threshold on a pair's displacement residual "
                  "per epoch ((0.2 mm)^2 at 100 Hz; sekimori.hpp says why)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--r-th", args->pipeline.sekimori.r_th,
                  "sekimori: r_th of eq. (7), agreeing pairs a sensor needs to be reliable "
                  "(default max(1, N - 2))")
      ->check(CLI::Range(1, kMaxSensors));
  cmd->add_option("--alpha", args->pipeline.consensus.alpha,
                  "consensus: false-rejection rate of the chi-square consistency test")
      ->check(CLI::Range(1e-12, 0.5))
      ->capture_default_str();
  cmd->add_option("--out", args->out, "Output odometry.csv (written whole or not at all)")
      ->required();
  cmd->add_option("--rate", args->pipeline.rate, "Epoch rate of the synchroniser, Hz")
      ->check(CLI::Range(0.1, 10000.0))
      ->capture_default_str();
  cmd->add_option("--max-row-interval", args->pipeline.max_row_interval,
                  "Longest interval one mice.csv row may cover, s (a sensor silent for longer "
                  "was still before its row)")
      ->check(CLI::Range(1e-4, 10.0))
      ->capture_default_str();
  cmd->add_option("--max-gap", args->pipeline.max_gap,
                  "Longest time all sensors may stay silent, s (a gap is no motion, written "
                  "epoch by epoch; a longer one is an error)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--initial-pose", args->initial_pose,
                  "Initial pose X,Y,THETA in the world frame (m, m, rad)")
      ->expected(3)
      ->delimiter(',');
  cmd->add_flag("--fuse-camera", args->pipeline.fuse_camera,
                "Fuse camera.csv position fixes with an EKF (adds pose covariance columns)");
  cmd->add_option("--camera-latency", args->pipeline.camera_latency,
                  "Delay from a fix's capture (camera.csv t) to its arrival, s: late fixes are "
                  "applied at their capture time")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--camera-sigma", args->pipeline.camera_sigma,
                  "Std. dev. of a camera fix, m, when camera.csv has no sx, sy")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_flag("--no-wheels", args->no_wheels,
                "Ignore wheels.csv (by default it is the fallback and plausibility check)");
  cmd->add_flag("--quiet", args->quiet, "Print nothing on success");
  cmd->callback([&action, args] { action = [args] { return run_odometry(*args); }; });
}

}  // namespace moa::cli
