#include "odometry_options.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>

#include "moa/formats/error.hpp"
#include "moa/runs/odometry_run.hpp"
#include "moa/runs/option_error.hpp"
#include "option_flags.hpp"

namespace moa::cli {

const CLI::Validator kFinite(
    [](std::string& text) -> std::string {
      double x = 0.0;
      if (!CLI::detail::lexical_cast(text, x)) return fmt::format("'{}' is not a number", text);
      if (!std::isfinite(x)) return fmt::format("{} is not a finite number", text);
      return {};
    },
    "FINITE", "finite");

CLI::Validator finite_within(double lo, double hi, bool open_low, bool open_high) {
  return CLI::Validator(
      [lo, hi, open_low, open_high](std::string& text) -> std::string {
        double x = 0.0;
        if (!CLI::detail::lexical_cast(text, x)) return fmt::format("'{}' is not a number", text);
        if (!std::isfinite(x)) return fmt::format("{} is not a finite number", text);
        if (std::isinf(hi) && (open_low ? !(x > lo) : !(x >= lo))) {
          return fmt::format("{}: must be {} {}", text, open_low ? ">" : ">=", lo);
        }
        if ((open_low ? !(x > lo) : !(x >= lo)) || (open_high ? !(x < hi) : !(x <= hi))) {
          return fmt::format("{}: must be within {}{}, {}{}", text, open_low ? "(" : "[", lo, hi,
                             open_high ? ")" : "]");
        }
        return {};
      },
      "NUMBER", "finite_within");
}

const CLI::Validator kPositive = finite_within(0.0, std::numeric_limits<double>::infinity(), true);
const CLI::Validator kNonNegative = finite_within(0.0, std::numeric_limits<double>::infinity());

CLI::Validator output_file_name() {
  return CLI::Validator(
      [](std::string& v) -> std::string {
        if (v.empty()) return "an empty file name";
        if (v[0] == '-') return "'" + v + "' is not a file name (write ./" + v + " for one)";
        return {};
      },
      "");
}

CLI::Validator output_file() {
  return CLI::Validator(
      [](std::string& v) -> std::string {
        if (std::string e = output_file_name()(v); !e.empty()) return e;
        std::error_code ec;
        if (v.back() == '/' || std::filesystem::is_directory(v, ec)) {
          return "'" + v + "' is a directory: name the file to write";
        }
        return {};
      },
      "");
}

CLI::Validator output_file_or_stdout() {
  return CLI::Validator(
      [](std::string& v) -> std::string { return v == "-" ? std::string{} : output_file()(v); },
      "");
}

void add_odometry_flags(CLI::App* cmd, OdometryFlags& f, bool live) {
  OdometryOptions& o = f.options;
  cmd->add_option("--estimator", f.estimator,
                  "Twist estimator: ls (all sensors, least squares), sekimori (pairwise voting, "
                  "Sekimori & Miyazaki), consensus (largest consistent set)" +
                      std::string(live ? ""
                                       : ", wheels (wheels.csv alone), oracle (least squares "
                                         "over the sensors without a simulated fault: needs "
                                         "faults.csv)"))
      ->check(live ? CLI::IsMember({"ls", "sekimori", "consensus"})
                   : CLI::IsMember({"ls", "sekimori", "consensus", "wheels", "oracle"}))
      ->capture_default_str();
  // Split by resolve_odometry_flags, not by CLI11's delimiter, which drops
  // empty names (m1,,m3 would read as m1,m3).
  cmd->add_option("--sensors", f.sensors,
                  "The sensors the estimator may use, by config name (e.g. m1,m3); default all")
      ->type_name("NAME[,NAME...]")
      ->check(CLI::Validator(
          [](std::string& v) -> std::string {
            if (v.empty() || v.front() == ',' || v.back() == ',' ||
                v.find(",,") != std::string::npos) {
              return "an empty sensor name in '" + v + "'";
            }
            return {};
          },
          ""));
  cmd->add_option("--e-th", o.sekimori.e_th,
                  "sekimori: E_th of eq. (7), m^2, threshold on a pair's displacement residual "
                  "per epoch ((0.2 mm)^2 at 100 Hz; core/sekimori.hpp says why)")
      ->check(kPositive)
      ->capture_default_str();
  cmd->add_option("--r-th", o.sekimori.r_th,
                  "sekimori: r_th of eq. (7), agreeing pairs a sensor needs to be reliable "
                  "(default max(1, N - 2))")
      ->check(CLI::Range(1, kMaxSensors));
  cmd->add_option("--alpha", o.consensus.alpha,
                  "consensus: false-rejection rate of the chi-square consistency test, 1e-12 to "
                  "below 0.5")
      ->check(finite_within(1e-12, 0.5, false, /*open_high=*/true))
      ->capture_default_str();
  cmd->add_flag("--no-motion-prior", f.no_motion_prior,
                "consensus: no motion prior (the robot's limits, config key limits); a minority "
                "subset is then judged against the wheels with its own covariance added");
  cmd->add_flag("--self-calibrate", f.self_calibrate,
                "Online self-calibration: each sensor's scale (both axes) and yaw offset "
                "estimated from the others while driving and applied to its counts "
                "(docs/self-calibration.md); a sensor whose estimate runs away is excluded");
  cmd->add_option("--self-calibration", f.self_calibration_out,
                  "With --self-calibrate (implied): write the calibration to this CSV, "
                  "about once a second per sensor (t,sensor,scale_x,scale_y,yaw_offset as "
                  "applied, then the filter's filter_scale_x,filter_scale_y,filter_yaw_offset and "
                  "their standard deviations filter_sd_*)")
      ->type_name("FILE")
      ->check(output_file());
  cmd->add_option(
         "--diagnostics", f.diagnostics_out,
         "Write every source's status per epoch to this CSV (t,source,test_ratio,fused,"
         "reason,bias,scale: each sensor's, the wheels', the motion prior's and the gyro's (imu) "
         "test statistic over its gate, whether the epoch's twist used it, and why not; the "
         "gyro's bias (rad/s) and scale after the epoch; docs/formats/log.md)")
      ->type_name("FILE")
      ->check(output_file());
  cmd->add_option("--self-calibration-gauge", f.self_calibration_gauge,
                  live ? "With --self-calibrate (implied): what fixes the common scale and yaw "
                         "of all sensors, which the redundancy cannot see: sensors (their "
                         "median keeps the configured values; the wheels gauge is moa "
                         "odometry's)"
                       : "With --self-calibrate (implied): what fixes the common scale and yaw "
                         "of all sensors, which the redundancy cannot see: sensors (default: "
                         "their median keeps the configured values) or wheels (the log's "
                         "wheels.csv; their systematic slip becomes the array's scale; "
                         "docs/self-calibration.md)")
      ->check(live ? CLI::IsMember({"sensors"}) : CLI::IsMember({"sensors", "wheels"}));
  cmd->add_option("--rate", o.rate, "Epoch rate of the synchroniser, Hz (0.1 to 10000)")
      ->check(finite_within(0.1, 10000.0))
      ->capture_default_str();
  cmd->add_option("--max-row-interval", f.max_row_interval,
                  "Longest interval one mice.csv row may cover, s (a sensor silent for longer "
                  "was still before its row); at most 61 epochs [default: 0.05, or 60 epochs "
                  "where that is shorter]")
      ->check(finite_within(1e-4, 10.0));
  cmd->add_option("--max-gap", o.max_gap,
                  "Longest time all sensors may stay silent, s (a gap is no motion, written "
                  "epoch by epoch; a longer one is an error); the silences summed over the log "
                  "may reach it plus one epoch per row")
      ->check(kPositive)
      ->capture_default_str();
  cmd->add_option("--initial-pose", f.initial_pose,
                  "Initial pose X,Y,THETA in the world frame (m, m, rad)")
      ->expected(3)
      ->delimiter(',')
      ->check(kFinite);
  cmd->add_flag("--no-imu", f.no_imu,
                live ? "Ignore the gyro (a --replay log's imu.csv, a --serial board's, --streams "
                       "imu lines; by default the consensus fuses it, config key imu; one sensor "
                       "is then refused for --replay)"
                     : "Ignore the gyro (imu.csv; by default the consensus fuses it, config key "
                       "imu; one sensor is then refused)");
  cmd->add_flag("--no-wheels", f.no_wheels,
                live ? "Ignore the wheels (a --replay log's wheels.csv, --streams wheels lines; "
                       "by default they are the fallback and plausibility check)"
                     : "Ignore wheels.csv (by default it is the fallback and plausibility check)");
  if (live) return;
  CLI::Option* fuse =
      cmd->add_flag("--fuse-camera", o.fuse_camera,
                    "Fuse camera.csv position fixes with an EKF (adds pose covariance columns)");
  cmd->add_option("--camera-latency", o.camera_latency,
                  "camera.csv's t minus the true capture time, s (a stamp at arrival: the delay): "
                  "the fix is applied at t - S once the epochs reach t [default: the config's "
                  "camera: {latency}, else 0]")
      ->check(finite_within(-60.0, 60.0));
  cmd->add_option("--camera-sigma", o.camera_sigma,
                  "Std. dev. of a camera fix, m, when camera.csv has no sx, sy")
      ->check(kPositive)
      ->capture_default_str();
  cmd->add_flag("--ekf-scale", o.ekf.estimate_scale,
                "With --fuse-camera: estimate the dead reckoning's linear and rotation scales "
                "(adds scale_v, scale_omega, sd_scale_v, sd_scale_omega columns)")
      ->needs(fuse);
}

std::vector<std::string> self_calibration_warnings(const OdometryOptions& o) {
  std::vector<std::string> out;
  if (!o.self_calibration.enabled) return out;
  if (o.estimator == EstimatorKind::kWheels) {
    out.emplace_back(
        "--self-calibrate with --estimator wheels: the mice are not used, nothing is learnt "
        "(the calibration stays 1, 1, 0)");
  } else if (count_sensors(o.sensors) < 3) {
    out.emplace_back(fmt::format(
        "--self-calibrate with {} sensor(s): it needs three or more (each sensor is predicted "
        "from the others); the calibration stays 1, 1, 0",
        count_sensors(o.sensors)));
  }
  return out;
}

OdometryOptions resolve_odometry_flags(const OdometryFlags& f, const io::RobotConfig& config,
                                       const std::string& config_path) {
  OdometryOptions o = f.options;
  o.max_row_interval =
      f.max_row_interval.value_or(OdometryOptions::default_max_row_interval(o.rate));
  o.consensus.motion_prior = !f.no_motion_prior;
  o.use_imu = !f.no_imu;
  o.self_calibration.enabled =
      f.self_calibrate || !f.self_calibration_out.empty() || !f.self_calibration_gauge.empty();
  if (!f.self_calibration_gauge.empty()) {
    const auto gauge = from_name<SelfCalibrationGauge>(f.self_calibration_gauge);
    if (!gauge) {
      throw io::Error(fmt::format("--self-calibration-gauge: unknown gauge '{}' (sensors, wheels)",
                                  f.self_calibration_gauge));
    }
    o.self_calibration.gauge = *gauge;
  }
  if (f.initial_pose.size() == 3) {
    o.initial = Pose2{{f.initial_pose[0], f.initial_pose[1]}, f.initial_pose[2]};
  }
  try {
    std::vector<std::string> sensors;
    for (const std::string& names : f.sensors) {
      for (std::size_t begin = 0;;) {
        const std::size_t comma = names.find(',', begin);
        sensors.push_back(names.substr(begin, comma - begin));
        if (comma == std::string::npos) break;
        begin = comma + 1;
      }
    }
    return io::resolve_odometry_options(o, f.estimator, sensors, f.no_wheels, config, config_path);
  } catch (const io::OptionError& e) {
    throw io::Error(with_flags(e));
  }
}

}  // namespace moa::cli
