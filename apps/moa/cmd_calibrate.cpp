// moa calibrate: where the sensors really sit (docs/formats/cli.md,
// docs/calibration.md). Parses the flags, runs io::calibrate_log
// (moa/runs/calibration_run.hpp: pairing, checks and report), writes the
// calibrated config and prints the report.
#include <fmt/core.h>

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "calibrate_wizard.hpp"
#include "commands.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/error.hpp"
#include "moa/runs/calibration_run.hpp"
#include "moa/runs/odometry_run.hpp"
#include "moa/runs/output_path.hpp"
#include "odometry_options.hpp"
#include "option_flags.hpp"

namespace moa::cli {
namespace {

struct CalibrateArgs {
  std::string config;
  std::string method;
  std::string log;
  std::string out;
  std::string push_x;
  std::string push_y;
  std::string spin;
  std::string imu_reference = "array";
  std::string reference;
  bool no_imu = false;
  io::CalibrationOptions options;
  bool json = false;
  bool quiet = false;
};

int calibrate_with_options(CalibrateArgs args) {
  const auto method = from_name<io::CalibrationMethod>(args.method);
  if (!method) throw io::Error(fmt::format("--method: unknown method '{}'", args.method));
  args.options.push_x = args.push_x;
  args.options.push_y = args.push_y;
  args.options.spin = args.spin;
  args.options.imu = !args.no_imu;
  args.options.imu_reference = *from_name<io::GyroReference>(args.imu_reference);
  if (!args.reference.empty()) {
    if (*method != io::CalibrationMethod::kExact) {
      throw io::Error(fmt::format("--reference is used by --method exact only, not by --method {}",
                                  args.method));
    }
    args.options.reference = from_name<io::ExactReference>(args.reference);
  }
  // The options are checked before the config is read, so that a wrong flag is named first.
  io::check_calibration_options(*method, args.log, args.options);
  std::vector<std::filesystem::path> inputs{args.config};
  for (const auto& dir : {std::filesystem::path(args.log), args.options.push_x, args.options.push_y,
                          args.options.spin}) {
    if (dir.empty()) continue;
    const auto files = io::resolve_log(dir).files();
    inputs.insert(inputs.end(), files.begin(), files.end());
  }
  io::refuse_output_onto_inputs(args.out, "--out", inputs);
  const io::RobotConfig config = io::read_config(args.config);
  const io::CalibrationSummary summary =
      io::calibrate_log(config, args.config, args.log, *method, args.options);
  if (const auto* exact = std::get_if<ExactCalibration>(&summary.result);
      exact != nullptr && exact->check.misfit()) {
    fmt::print(stderr,
               "moa calibrate: warning: the calibrated model does not explain the data; written "
               "anyway (--force), see the report's model check\n");
  }
  io::write_config(summary.calibrated, args.out);
  if (args.json) {
    fmt::print("{}\n", summary.to_json(args.out));
  } else if (!args.quiet) {
    fmt::print("{}calibrated config written to {}\n", summary.full_report(), args.out);
  }
  return 0;
}

int run_calibrate(const CalibrateArgs& args) {
  try {
    return calibrate_with_options(args);
  } catch (const io::OptionError& e) {
    throw io::Error(with_flags(e));
  }
}

}  // namespace

void add_calibrate(CLI::App& app, Action& action) {
  auto args = std::make_shared<CalibrateArgs>();
  auto* cmd = app.add_subcommand(
      "calibrate",
      "Sensor positions, yaw, scale and mirroring from a log with reference twists "
      "(kimlee, exact) or from a push and a spin (guided); writes a config v1");
  cmd->add_option("--config", args->config, "Nominal robot config v1 (YAML)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--method", args->method,
                  "kimlee: Kim & Lee Section IV (positions only); exact: all extrinsics against "
                  "wheels.csv; guided: pushes and a spin, no reference")
      ->check(CLI::IsMember({"kimlee", "exact", "guided"}));
  cmd->add_option("--log", args->log, "Log directory with mice.csv and wheels.csv (kimlee, exact)")
      ->check(CLI::ExistingPath);
  cmd->add_option("--out", args->out, "Calibrated config v1 (written whole or not at all)")
      ->required()
      ->check(output_file());
  cmd->add_option("--push-x", args->push_x, "guided: log of a push along the robot's x axis")
      ->check(CLI::ExistingPath);
  cmd->add_option("--push-y", args->push_y, "guided: log of a push along the robot's y axis")
      ->check(CLI::ExistingPath);
  cmd->add_option("--spin", args->spin, "guided: log of whole turns about the robot's centre")
      ->check(CLI::ExistingPath);
  cmd->add_option("--distance", args->options.distance, "guided: length of each push, m");
  cmd->add_option("--turns", args->options.turns, "guided: number of whole turns of the spin");
  cmd->add_option("--max-row-interval", args->options.max_row_interval,
                  "Longest interval one mice.csv row may cover, s")
      ->check(kPositive)
      ->capture_default_str();
  cmd->add_option("--min-interval", args->options.min_interval,
                  "kimlee, exact: merge consecutive wheels.csv rows into intervals of at least "
                  "this many seconds (default: 0.05 for exact, 0 for kimlee)")
      ->check(kNonNegative);
  cmd->add_option("--measurements", args->options.measurements,
                  "kimlee, exact: sum the intervals into this many measurements of equal "
                  "duration (default: 10 for kimlee, the paper's M; every interval for exact); 0: "
                  "every interval")
      ->check(kNonNegative);
  cmd->add_option("--distance-sd", args->options.tolerances.distance_sd,
                  "guided: 1-sigma of the push distance, m")
      ->check(kNonNegative)
      ->capture_default_str();
  cmd->add_option("--turn-sd", args->options.tolerances.turn_sd,
                  "guided: 1-sigma of the spin's total angle, rad")
      ->check(kNonNegative)
      ->capture_default_str();
  cmd->add_option("--centre-sd", args->options.tolerances.centre_sd,
                  "guided: 1-sigma of the spin centre per axis, m")
      ->check(kNonNegative)
      ->capture_default_str();
  cmd->add_option("--heading-sd", args->options.tolerances.heading_sd,
                  "guided: 1-sigma of the robot's turning during a push, rad")
      ->check(kNonNegative)
      ->capture_default_str();
  cmd->add_flag("--force", args->options.force,
                "exact: write a calibration whose model does not explain the data (residual far "
                "above the counts' noise, information not positive definite) with a warning "
                "instead of refusing it");
  cmd->add_flag("--no-imu", args->no_imu,
                "Leave the gyro alone (by default, when the log or guided's spin has imu.csv, "
                "or --guided --live's spin has gyro rows, its scale, bias and latency are "
                "calibrated into the config's imu: block)");
  cmd->add_option(
         "--imu-reference", args->imu_reference,
         "The gyro's reference rotation: array (the mice at the "
         "calibrated mounts; default), array-nominal (at the mounts of --config) or "
         "wheels (wheels.csv's omega: slip biases the scale) or camera (camera.csv's theta, "
         "differenced); --guided --live: array only")
      ->check(CLI::IsMember({"array", "array-nominal", "wheels", "camera"}))
      ->capture_default_str();
  cmd->add_option("--reference", args->reference,
                  "exact: wheels (wheels.csv's twists) or camera (camera.csv's poses with theta, "
                  "or its positions only with the sensors' mean yaw as the gauge: the mounts, "
                  "every sensor's latency and the camera's); default wheels when the log has "
                  "wheels.csv, else camera")
      ->check(CLI::IsMember({"wheels", "camera"}));
  cmd->add_option("--max-offset", args->options.max_offset,
                  "exact against the camera: s, range of the coarse latency search around the "
                  "configured camera latency")
      ->check(kPositive)
      ->capture_default_str();
  cmd->add_option("--speed-knots", args->options.speed_knots,
                  "exact against wheels.csv: m/s, comma-separated, 2 to 8 strictly increasing "
                  "knots: fit each sensor's ratio of counted to true displacement at those "
                  "ground speeds (the config's speed_scale)")
      ->delimiter(',');
  cmd->add_option("--window", args->options.window,
                  "exact against the camera: s, least window between two fixes")
      ->check(kPositive)
      ->capture_default_str();
  cmd->add_flag("--json", args->json, "Print the report as one JSON object (SI units)");
  cmd->add_flag("--quiet", args->quiet, "Print nothing on success");
  // --guided [--live]: the live, step-by-step guided calibration (calibrate_wizard.cpp).
  auto wizard = std::make_shared<WizardArgs>();
  add_wizard_flags(cmd, *wizard);
  cmd->callback([&action, args, wizard] {
    if (wizard->live) {
      wizard->config = args->config;
      wizard->out = args->out;
      wizard->distance = args->options.distance;
      wizard->turns = args->options.turns;
      wizard->tolerances = args->options.tolerances;
      wizard->imu = !args->no_imu;
      wizard->imu_reference = args->imu_reference;
      action = [wizard] {
        try {
          return run_wizard(*wizard);
        } catch (const io::OptionError& e) {  // the gyro's refusal names its flags
          throw io::Error(with_flags(e));
        }
      };
      return;
    }
    if (wizard->guided && args->method.empty()) args->method = "guided";
    // A usage error (exit 2), as CLI11's own for a required option.
    if (args->method.empty()) throw CLI::RequiredError("--method (or --guided)");
    action = [args, wizard] {
      refuse_live_flags(*wizard);
      return run_calibrate(*args);
    };
  });
}

}  // namespace moa::cli
