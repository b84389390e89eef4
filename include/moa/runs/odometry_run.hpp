// The odometry pipeline (moa/core/odometry.hpp) over the files of a log
// directory: mice.csv, and when present and asked for wheels.csv, imu.csv,
// camera.csv, faults.csv, merged in time order. `moa odometry`, the
// experiments and the Python bindings all run this.
#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "moa/core/odometry.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/log.hpp"
#include "moa/runs/run_loop.hpp"

namespace moa::io {

/// The files of a log (log format v1), found from the directory or its
/// mice.csv: the one resolver of "log directory or mice.csv".
struct LogFiles {
  std::filesystem::path dir;
  std::filesystem::path mice;
  std::optional<std::filesystem::path> wheels, imu, camera, truth, faults;
  /// mice and the optional files present: what an output must not name.
  std::vector<std::filesystem::path> files() const;
};
/// Throws io::Error when `log` is neither a directory with mice.csv nor a file.
LogFiles resolve_log(const std::filesystem::path& log);

/// The pipeline's options as a front end names them: `estimator` by name,
/// `sensors` by config name (empty: all), wheels off with `no_wheels`;
/// then validated (OdometryOptions::validate). `moa odometry`, `moa live`
/// and the Python bindings resolve their options with this. Throws
/// io::OptionError (runs/option_error.hpp) naming the options by their
/// field ("sensors: unknown sensor 'x' (robot.yaml has m1, m2)", "estimator
/// wheels and no_wheels exclude each other"), which the front end renders
/// in its own words; io::Error "invalid option: rate: must be positive and
/// finite (Hz)" for options that fail validate().
OdometryOptions resolve_odometry_options(OdometryOptions options, std::string_view estimator,
                                         const std::vector<std::string>& sensors, bool no_wheels,
                                         const RobotConfig& config, const std::string& config_path);

/// The log's gyro as the pipeline takes it, for `moa odometry` and `moa live
/// --replay`: imu.csv opened when options.use_imu, the log has one and the
/// estimator is the consensus (the gyro goes to the consensus only), else
/// null. One sensor takes its rotation from the gyro: for a one-sensor config
/// (estimator not wheels) throws io::Error "LOG/mice.csv: one sensor needs a
/// gyro for its rotation: --no-imu given" (or the estimator is not the
/// consensus), and, unless `other_gyro` (a live run's streams may bring
/// one), when the log has no imu.csv or fewer than two data rows in it.
std::unique_ptr<ImuReader> open_log_imu(const RobotConfig& config, const LogFiles& log,
                                        const OdometryOptions& options, bool other_gyro = false);

/// The streams of a log beside its mice.csv, as the pipeline takes them.
struct LogStreams {
  std::unique_ptr<WheelsReader> wheels;  ///< wheels.csv, when options.use_wheels
  std::unique_ptr<ImuReader> imu;        ///< imu.csv (open_log_imu)
  std::unique_ptr<CameraReader> camera;  ///< camera.csv, when options.fuse_camera
  bool any() const { return wheels || imu || camera; }
};
/// Opens the log's streams as `moa odometry` reads them, for it and `moa
/// live --replay`: wheels.csv when options.use_wheels and it exists, the
/// gyro as open_log_imu says, camera.csv when options.fuse_camera (throws
/// io::Error "LOG/camera.csv: camera fusion needs camera.csv in the log"
/// without one, unless `other_streams`: a live run's streams may bring the
/// fixes and the gyro).
LogStreams open_log_streams(const RobotConfig& config, const LogFiles& log,
                            const OdometryOptions& options, bool other_streams = false);

using StepCallback = std::function<void(const OdometryStep&)>;
/// Called now and then with the mice rows read so far and their time (s).
using ProgressCallback = std::function<void(std::size_t rows, double t)>;

/// Runs the pipeline (the run loop of runs/run_loop.hpp) over the log's
/// files: wheels.csv is fed when options.use_wheels and it
/// exists, imu.csv when options.use_imu, it exists and the estimator is
/// the consensus, camera.csv when options.fuse_camera (required then), faults.csv
/// (or `faults`) when the estimator is the oracle (required then). Throws
/// io::Error naming the file, line or option on anything wrong. A selected
/// sensor that never reports is refused for least squares and the oracle
/// (they would take it as still) and a warning for the robust estimators.
OdometryRun run_odometry(const RobotConfig& config, const std::string& config_path,
                         const LogFiles& log, const OdometryOptions& options,
                         const StepCallback& on_step, const ProgressCallback& progress = {});

/// run_odometry writing odometry.csv (written whole on success, else not at all)
/// and, when `calibration_out` is not empty and options.self_calibration is
/// enabled, the self-calibration's estimates (formats/self_calibration_csv.hpp),
/// and, when `diagnostics_out` is not empty, every source's status per epoch
/// (formats/diagnostics_csv.hpp).
OdometryRun write_odometry(const RobotConfig& config, const std::string& config_path,
                           const LogFiles& log, const OdometryOptions& options,
                           const std::filesystem::path& out, const ProgressCallback& progress = {},
                           const std::filesystem::path& calibration_out = {},
                           const std::filesystem::path& diagnostics_out = {});

/// Builds the pipeline in place on the heap (it is large), or throws
/// io::Error naming `config_path` for a geometry the estimator refuses and
/// the option for invalid options.
std::unique_ptr<Odometry> make_odometry(const RobotConfig& config, const std::string& config_path,
                                        double t0, const OdometryOptions& options);

}  // namespace moa::io
