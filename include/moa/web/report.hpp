// `moa report`: one self-contained HTML page with plots of a run.
//
// Inputs: the robot config the odometry was made with, the log directory
// (mice.csv, optional camera.csv), the odometry.csv of `moa odometry`, and
// optionally truth.csv and a calibrated config. Every file is streamed or
// read once; long runs are binned in time so that each plotted series has
// at most ReportOptions::max_points points and the page stays small.
//
// Quantities plotted (robot frame R, world frame W, SI units):
//   trajectory          (x, y)_W of the estimate, the truth, the camera fixes
//   translation error   |p_est(t) - p_truth(t)|                            m
//   heading error       |wrap(theta_est(t) - theta_truth(t))|              rad
//                       truth interpolated at the estimate's time (evaluate.hpp)
//   point speed         s_i = |v + omega J p_i|  (docs/formats/config.md model,     m/s
//                       Kim & Lee eq. (6)) from the odometry twist (v, omega)_R
//                       and the mount p_i of the config, against max_speed_i
//   selection           per sensor and epoch: "used", or the reason written in
//                       the odometry's `excluded` column (e.g. "inconsistent/over-speed")
// Binned series keep, per time bin of width (t_last - t_first) / max_points,
// the last row's pose (trajectory) and the largest error and point speed.
#pragma once

#include <array>
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "moa/analysis/evaluate.hpp"
#include "moa/core/array.hpp"
#include "moa/formats/config.hpp"
#include "moa/runs/run_summary.hpp"

namespace moa::io {

struct ReportInputs {
  std::filesystem::path config;                ///< robot config v1 the odometry was made with
  std::filesystem::path log;                   ///< log directory (mice.csv, optional camera.csv)
  std::filesystem::path odometry;              ///< odometry.csv of `moa odometry`
  std::optional<std::filesystem::path> truth;  ///< truth.csv: adds the error plots
  std::optional<std::filesystem::path> calibration;  ///< config v1 from `moa calibrate`
  /// self-calibration.csv of `moa odometry --self-calibration`: adds the plot
  /// of each sensor's estimated scale over time.
  std::optional<std::filesystem::path> self_calibration;
  /// diagnostics.csv of `moa odometry --diagnostics`: with a gyro (imu rows),
  /// adds the heading's source to the gyro section.
  std::optional<std::filesystem::path> diagnostics;
  std::string title;  ///< page title; empty: named after the log directory
  std::string note;   ///< a paragraph under the title (plain text), e.g. how the run was made
};

struct ReportOptions {
  /// Most points of any plotted series (time bins; camera fixes by stride).
  std::size_t max_points = 2000;
};

/// One time bin of the odometry (the first row has a bin of its own).
struct ReportBin {
  double t = 0.0;  ///< s, time of the bin's last row
  Pose2 pose;      ///< world_T_robot at t
  /// Largest errors in the bin (m, rad); NaN when no row of it is within truth.
  double translation_error = 0.0;
  double heading_error = 0.0;
  /// Largest point speed s_i of each sensor in the bin (m/s).
  std::array<double, kMaxSensors> speed{};
};

/// A run of time over which one timeline row kept the same state.
struct TimelineSegment {
  int row = 0;         ///< sensor index; the sensor count for the twist source row
  int state = 0;       ///< index into ReportModel::states
  double t0 = 0.0;     ///< s, start of the first bin of the run
  double t1 = 0.0;     ///< s, end of the last bin of the run
  double share = 1.0;  ///< fraction of the run's epochs that were in `state`
};

/// Per-sensor counts over the whole run.
struct SensorSummary {
  std::size_t used = 0;  ///< epochs in the estimate
  /// Epochs excluded, per state (index into ReportModel::states).
  std::vector<std::size_t> excluded;
  double max_speed = 0.0;      ///< m/s, largest point speed s_i
  std::size_t over_rated = 0;  ///< epochs with s_i above the rated max_speed
  std::size_t mice_rows = 0, lift_rows = 0, overflow_rows = 0;
  std::optional<int> min_squal;  ///< lowest SQUAL in mice.csv, if reported
};

/// One sensor's online self-calibration over time (self-calibration.csv),
/// relative to its configured mount: scale 1 and yaw offset 0 as configured.
struct ScaleSeries {
  std::vector<double> t;                 ///< s
  std::vector<double> scale_x, scale_y;  ///< counts per configured count
  std::vector<double> yaw_offset;        ///< rad
};

/// The gyro over a run, from the `imu` rows of diagnostics.csv.
struct GyroCounts {
  std::size_t epochs = 0;        ///< epochs of the file (its `prior` rows: one per epoch)
  std::size_t readings = 0;      ///< epochs with a gyro reading (`imu` rows)
  std::size_t heading = 0;       ///< of them, the heading was the gyro's (fused = 1)
  std::size_t saturated = 0;     ///< reading at full scale: not used
  std::size_t inconsistent = 0;  ///< tested beyond the gate against the array: not used
  std::size_t over_gate = 0;     ///< test ratio above 1: the array's rotation disagreed
  double max_test = 0.0;         ///< largest test ratio (1: the gate); 0 when none tested
  /// The gyro's calibration after the last `imu` row that has it (rad/s, -);
  /// empty for files written before those columns.
  std::optional<double> bias, scale;
};

/// Everything the page shows, computed from the inputs.
struct ReportModel {
  std::string title;
  ReportInputs inputs;
  RobotConfig config;
  std::optional<RobotConfig> calibrated;  ///< in the config's sensor order

  std::size_t epochs = 0;  ///< odometry rows
  /// The run's summary counted from odometry.csv: the same object and verdict
  /// that `moa odometry` printed (runs/run_summary.hpp).
  RunSummary summary;
  double t_first = 0.0, t_last = 0.0;
  double distance = 0.0;  ///< m, path length of the estimate
  Pose2 final_pose;
  std::vector<ReportBin> bins;

  std::vector<StampedPose> truth;  ///< decimated to at most max_points
  std::optional<TrajectoryError> errors;
  /// quantisation_floor() of the config on the truth's path: the summary's verdict.
  std::optional<TrajectoryError> floor;
  std::vector<Eigen::Vector2d> camera;  ///< fixes (decimated)
  std::size_t camera_rows = 0;

  /// Selection columns (`used`, `excluded`, `source`) present in odometry.csv.
  bool has_selection = false;
  /// Timeline states: "used" first, then exclusion reasons and twist sources
  /// ("mice", "wheels", "hold") in order of appearance.
  std::vector<std::string> states;
  std::vector<TimelineSegment> timeline;
  std::vector<SensorSummary> sensors;
  /// Epochs per state of the twist source row.
  std::vector<std::size_t> sources;
  /// With a self-calibration input: per config sensor (empty series for a
  /// sensor the file has no row of), at most max_points samples each.
  std::vector<ScaleSeries> self_calibration;
  /// The log has imu.csv: the page has a gyro section.
  bool has_imu = false;
  /// With a diagnostics input.
  std::optional<GyroCounts> gyro;
};

/// Reads and checks the inputs. Throws io::Error "FILE:LINE: what" (or
/// "FILE: what") for a missing or malformed file, and for sensor names that
/// disagree between the config, mice.csv, odometry.csv and the calibration.
ReportModel build_report(const ReportInputs& inputs, const ReportOptions& options = {});

/// The page: HTML with the plotting library, the data and the script inlined,
/// no reference to anything outside itself.
std::string render_report(const ReportModel& model);

/// build_report + render_report into `out`, atomically: on any error no
/// file is left behind.
void write_report(const ReportInputs& inputs, const std::filesystem::path& out,
                  const ReportOptions& options = {});

}  // namespace moa::io
