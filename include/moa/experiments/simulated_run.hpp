// One simulated run of an experiment, made the way a user would make it:
// `moa simulate` writes the log, `moa odometry` runs the library pipeline
// on its files, `moa evaluate` compares with truth.csv. The experiment calls
// the same library functions those commands call, in the same order, so
// every figure comes with the moa calls that reproduce it exactly.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "moa/analysis/evaluate.hpp"
#include "moa/core/odometry.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/self_calibration_csv.hpp"

namespace moa::experiments {

/// An estimation method compared by an experiment: a name and the pipeline
/// options, which odometry_flags() turns into `moa odometry` flags.
struct Method {
  std::string name;
  OdometryOptions options;
};

/// The method `name`: the pipeline's default options with `estimator`, and
/// self-calibration on when `self_calibrate`.
Method method_of(std::string name, EstimatorKind estimator, bool self_calibrate = false);

/// The `moa odometry` flags that give `options` (those that differ from
/// the defaults: estimator, sensors, wheels, imu, camera fusion and latency,
/// self-calibration on with its default options).
/// Throws std::invalid_argument for an option the command line cannot say.
std::vector<std::string> odometry_flags(const OdometryOptions& options,
                                        const io::RobotConfig& config);

/// One method's figures on one run.
struct RunRecord {
  std::uint64_t seed = 0;
  TrajectoryError error;
  std::vector<std::string> reproduce;  ///< moa calls; $OUT is a scratch directory
  /// With run(method, true) and self-calibration on: the rows of the
  /// self-calibration.csv that `moa odometry --self-calibration` writes.
  std::vector<io::SelfCalibrationRow> calibration;
};

class SimulatedRun {
 public:
  /// Simulates built-in scenario `scenario` with `seed` into a new
  /// directory under `scratch` (as `moa simulate --scenario S --seed N`).
  SimulatedRun(const std::string& scenario, std::uint64_t seed,
               const std::filesystem::path& scratch);
  ~SimulatedRun();
  SimulatedRun(const SimulatedRun&) = delete;
  SimulatedRun& operator=(const SimulatedRun&) = delete;

  /// Runs the method as `moa odometry` does, then evaluates it as `moa
  /// evaluate` does. With `keep_calibration` and the method's
  /// self-calibration on, also keeps the estimates it writes (RunRecord::calibration).
  RunRecord run(const Method& method, bool keep_calibration = false) const;

  const std::filesystem::path& dir() const { return dir_; }
  const io::RobotConfig& config() const { return config_; }
  std::uint64_t seed() const { return seed_; }
  const std::string& scenario() const { return scenario_; }
  /// Scenario parameters the experiment may need (camera latency).
  double camera_latency() const { return camera_latency_; }

 private:
  std::string scenario_;
  std::uint64_t seed_;
  std::filesystem::path dir_;
  io::RobotConfig config_;
  double camera_latency_ = 0.0;
  mutable int runs_ = 0;
};

/// A directory for scratch files, removed with its contents when this goes.
class ScratchDirectory {
 public:
  explicit ScratchDirectory(const std::string& prefix);
  ~ScratchDirectory();
  ScratchDirectory(const ScratchDirectory&) = delete;
  ScratchDirectory& operator=(const ScratchDirectory&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

/// Mean and sample standard deviation over runs.
struct Spread {
  double mean = 0.0, sd = 0.0;
};
Spread spread(const std::vector<double>& values);

}  // namespace moa::experiments

namespace moa::io {
class JsonWriter;
}

namespace moa::experiments {

/// Mean over the runs of each run's figures.
struct MeanError {
  Spread max_translation, rms_translation, max_heading, rms_heading;  ///< m, rad
  Spread final_translation;                                           ///< m, the last estimate's
};
MeanError mean_error(const std::vector<RunRecord>& runs);

/// Writes "max_translation_m", "rms_translation_m", "max_heading_rad",
/// "rms_heading_rad", "final_translation_m" (means), "sd_..." of the max
/// errors over the runs, and "runs" (each with "final_heading_rad" too).
void write_runs(io::JsonWriter& json, const std::vector<RunRecord>& runs);

}  // namespace moa::experiments
