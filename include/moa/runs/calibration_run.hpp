// Calibration over the files of a log, with its report: what `moa
// calibrate`, the Python bindings and any other front end run.
//
//   kimlee, exact   mice.csv against the reference twists of wheels.csv
//   guided          count totals of a push along x (and y) and a spin
//   the gyro        with imu.csv in the log (guided: the spin's), its scale,
//                   bias and latency against a reference rotation
//                   (calibration/gyro_calibration.hpp, GyroReference)
//
// Pairing of mice counts and reference (kimlee, exact): each wheels.csv row
// is the twist averaged over the interval from the previous row to its t,
// so the mice rows are integrated over exactly those intervals
// (IntervalAccumulator: a row's counts spread in proportion to overlap, as
// the Synchroniser does); the first wheels row only opens the first
// interval, and intervals outside the span of mice.csv are not used.
// min_interval merges consecutive wheels rows (duration-weighted mean
// twist, reference_intervals()) into longer intervals when the rows are
// shorter than the mice rows.
//
// Why in io and not in calibration: this reads wheels.csv and mice.csv (the
// guided recordings too) and writes its report as JSON with io::JsonWriter,
// as io::run_odometry runs the pipeline over a log. The calibration layer
// keeps what needs no file: the solvers, the pairing (IntervalAccumulator,
// reference_intervals, merge_samples) and the plausibility checks.
#pragma once

#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "moa/calibration/calibrate.hpp"
#include "moa/calibration/exact.hpp"
#include "moa/calibration/guided.hpp"
#include "moa/calibration/gyro_calibration.hpp"
#include "moa/calibration/kimlee.hpp"
#include "moa/calibration/pose_reference.hpp"
#include "moa/calibration/speed_scale.hpp"
#include "moa/core/names.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/log.hpp"

namespace moa::io {

enum class CalibrationMethod { kKimLee, kExact, kGuided };

/// What the gyro is calibrated against (kimlee, exact; docs/calibration.md).
///   array          the array's rotation: mice.csv over the gyro's rows,
///                  least squares at the mounts this run calibrated (default:
///                  the gyro then agrees with the array the config written
///                  describes, which is what the consensus fuses it with; the
///                  mice do not slip)
///   array-nominal  the same at the mounts of the config given (when the
///                  reference twist is worse than the nominal mounts)
///   wheels         wheels.csv's omega (a slipping wheel over-reads its turns:
///                  the gyro's scale comes out low by the slip, several %)
///   camera         camera.csv's theta, differenced between fixes (the
///                  latency is then relative to the camera's clock: its
///                  capture time t)
enum class GyroReference { kArray, kArrayNominal, kWheels, kCamera };

/// What the exact method calibrates the mounts against.
///   wheels   wheels.csv's twists (the default when the log has wheels.csv)
///   camera   camera.csv's poses with theta (motion capture): the mounts,
///            every sensor's latency and the camera's latency relative to the
///            array (calibration/pose_reference.hpp; the default without
///            wheels.csv)
enum class ExactReference { kWheels, kCamera };

}  // namespace moa::io

template <>
struct moa::EnumNames<moa::io::GyroReference> {
  static constexpr std::array<NameEntry<io::GyroReference>, 4> kTable{{
      {io::GyroReference::kArray, "array"},
      {io::GyroReference::kArrayNominal, "array-nominal"},
      {io::GyroReference::kWheels, "wheels"},
      {io::GyroReference::kCamera, "camera"},
  }};
};

template <>
struct moa::EnumNames<moa::io::ExactReference> {
  static constexpr std::array<NameEntry<io::ExactReference>, 2> kTable{{
      {io::ExactReference::kWheels, "wheels"},
      {io::ExactReference::kCamera, "camera"},
  }};
};

template <>
struct moa::EnumNames<moa::io::CalibrationMethod> {
  static constexpr std::array<NameEntry<io::CalibrationMethod>, 3> kTable{{
      {io::CalibrationMethod::kKimLee, "kimlee"},
      {io::CalibrationMethod::kExact, "exact"},
      {io::CalibrationMethod::kGuided, "guided"},
  }};
};

namespace moa::io {

struct CalibrationOptions {
  /// kimlee, exact: longest interval one mice.csv row may cover, s.
  double max_row_interval = 0.05;
  /// kimlee, exact: merge consecutive wheels.csv rows into intervals of at
  /// least this many seconds. Unset: 0.05 for exact (sums of counts over
  /// longer intervals carry less quantisation), 0 for kimlee.
  std::optional<double> min_interval;
  /// kimlee, exact: sum the intervals into this many measurements of equal
  /// duration; 0: every interval. Unset: 10 for kimlee (the paper's M), 0
  /// for exact.
  std::optional<int> measurements;
  /// guided: log directories (or mice.csv files) of a push along the
  /// robot's x axis, optionally one along y, and whole turns about the
  /// robot's centre.
  std::filesystem::path push_x, push_y, spin;
  std::optional<double> distance;  ///< guided: m, length of each push
  std::optional<double> turns;     ///< guided: whole turns of the spin (negative: clockwise)
  GuidedTolerances tolerances;     ///< guided: 1-sigma of the procedure
  /// exact: return a calibration whose model does not explain the data
  /// (ExactModelCheck::misfit()) with a warning instead of refusing it.
  bool force = false;
  /// Calibrate the gyro too when the log (guided: the spin's recording) has
  /// imu.csv: its scale, bias and latency into the config's imu: block.
  bool imu = true;
  GyroReference imu_reference = GyroReference::kArray;
  /// exact: the reference; unset: wheels when the log has wheels.csv, else camera.
  std::optional<ExactReference> reference;
  /// exact against the camera: s, the coarse latency search's range around
  /// the configured camera latency (clocks further apart need more).
  double max_offset = 1.0;
  /// exact against the camera: s, least window between two fixes.
  double window = 0.2;
  /// exact against wheels.csv: m/s, the knots of each sensor's speed scale
  /// (calibration/speed_scale.hpp), written as `speed_scale` into the
  /// calibrated config; empty: no speed scale is fitted (a table in the
  /// config is kept, its counts undone before the mount fit).
  std::vector<double> speed_knots;
  /// nullopt when the numbers can be used, else the first field out of its
  /// bounds (core/options_check.hpp): max_row_interval, max_offset and window positive,
  /// min_interval and measurements not negative, distance positive, turns
  /// finite and not 0, every tolerance positive. Which options a method
  /// needs is check_calibration_options'.
  OptionCheck validate() const;
};

/// Checks that the options fit the method (`log` empty: none given); throws
/// io::Error in the command line's words ("--method guided needs --spin DIR").
void check_calibration_options(CalibrationMethod method, const std::filesystem::path& log,
                               const CalibrationOptions& options);

/// What every method reports per sensor.
struct SensorCalibrationReport {
  std::string name;
  SensorMount nominal;
  SensorMount calibrated;
  MountVector sigma = MountVector::Zero();             ///< 1-sigma of (px, py, yaw, sx, sy)
  std::array<bool, kMountParameters> estimated{};      ///< false: kept at nominal
  bool mirror_from_data = false;                       ///< mirroring decided by the data
  std::optional<double> residual_rms;                  ///< m/s (kimlee, exact)
  std::optional<double> push_misfit;                   ///< m (guided)
  std::optional<MountVector> information_eigenvalues;  ///< exact: observability.hpp
  std::optional<SpeedScaleFit> speed_scale;            ///< exact with speed_knots
};

/// How a calibration's solve ended, as Ceres' Summary::termination_type.
enum class CalibrationTermination {
  kConverged,           ///< solved; the data determined what the method estimates
  kNotConverged,        ///< exact: the optimiser stopped before converging (rough)
  kModelMisfit,         ///< exact: the model does not explain the data (kept with --force)
  kUnderdetermined,     ///< kimlee: S rank deficient, a minimum-norm correction
  kTooFewMeasurements,  ///< kimlee: M < 2N - 2 (Kim & Lee eq. (49))
};

}  // namespace moa::io

template <>
struct moa::EnumNames<moa::io::CalibrationTermination> {
  static constexpr std::array<NameEntry<io::CalibrationTermination>, 5> kTable{{
      {io::CalibrationTermination::kConverged, "converged"},
      {io::CalibrationTermination::kNotConverged, "not-converged"},
      {io::CalibrationTermination::kModelMisfit, "model-misfit"},
      {io::CalibrationTermination::kUnderdetermined, "underdetermined"},
      {io::CalibrationTermination::kTooFewMeasurements, "too-few-measurements"},
  }};
};

namespace moa::io {

/// The gyro's calibration (imu.csv against `reference`).
struct GyroCalibrationReport {
  GyroReference reference = GyroReference::kArray;
  std::filesystem::path imu;  ///< imu.csv
  GyroOptions nominal;        ///< the config's imu: block (defaults when it had none)
  GyroCalibration result;
  std::size_t reference_gaps = 0;  ///< array: gyro intervals without a usable array twist

  /// "gyro against the R" and a row per parameter: nominal, calibrated,
  /// 1-sigma (lines end in '\n').
  std::string table() const;
};

/// A calibration's result and report, as Ceres' Solver::Summary.
struct CalibrationSummary {
  CalibrationMethod method = CalibrationMethod::kExact;
  /// The first that applies, in the order of CalibrationTermination's values
  /// after kConverged: misfit before non-convergence (exact), rank before
  /// the count of measurements (kimlee).
  CalibrationTermination termination = CalibrationTermination::kConverged;
  /// The rule, as Ceres' IsSolutionUsable: termination is kConverged. A
  /// usable calibration may still carry warnings (parameters kept at
  /// nominal, implausible values): they say what to check, not that the
  /// solve failed.
  bool usable = false;
  /// The nominal config with the calibrated mounts: what `moa calibrate --out` writes.
  RobotConfig calibrated;
  std::vector<SensorCalibrationReport> sensors;
  /// Facts about the data and the solve, one line each (the report's head).
  std::vector<std::string> facts;
  std::vector<std::string> warnings;
  /// The method's own result.
  std::variant<KimLeeCalibration, ExactCalibration, GuidedCalibration> result;
  /// exact against the camera: the latencies (the mounts are in `result`).
  std::optional<PoseReferenceCalibration> pose_reference;
  /// The gyro's, when the log has imu.csv and options.imu (kimlee, exact).
  std::optional<GyroCalibrationReport> gyro;

  /// One line: method, sensors, the largest 1-sigma, warnings.
  std::string brief_report() const;
  /// The full text report: facts, a table per sensor, warnings (lines end in '\n').
  std::string full_report() const;
  /// One JSON object (SI units, no newline); `out`, when given, as its "out" member.
  std::string to_json(std::string_view out = {}) const;
};

/// A spin held in memory (`moa calibrate --guided --live`): what `moa
/// calibrate --method guided` reads from the spin's mice.csv and imu.csv.
struct SpinRecording {
  double start = 0.0;           ///< s: each sensor's first row accumulates from here
  std::vector<SensorRow> mice;  ///< in time order
  std::vector<ImuRow> imu;      ///< in time order
  std::string mice_where = "the spin's mice rows";  ///< named in messages
  std::string imu_where = "the spin's gyro rows";   ///< named in messages
};

/// The gyro of `spin` calibrated against the array's rotation at the mounts
/// of r.calibrated (the guided calibration's, which must have converged),
/// as `moa calibrate --method guided` does with the spin's imu.csv: the fit
/// into r.gyro and r.calibrated.imu, its facts and warnings into `r`.
/// `config`: the nominal config (its imu: block, if any, is the nominal).
/// Throws io::OptionError (runs/option_error.hpp: the front end renders its
/// option names, "{no_imu}") when the fit is refused, io::Error on bad rows.
void calibrate_spin_gyro(CalibrationSummary& r, const RobotConfig& config,
                         const SpinRecording& spin, const CalibrationOptions& options = {});

/// Calibrates `config` (read from `config_path`) with `method` from the log
/// `log` (kimlee, exact: a directory with mice.csv and wheels.csv; guided:
/// empty, the recordings are in `options`). Throws io::Error naming the
/// file, row or option on anything wrong, when the method cannot compute a
/// result, and (exact, unless options.force) when the calibrated model does
/// not explain the data (docs/calibration.md, "Refused calibrations").
CalibrationSummary calibrate_log(const RobotConfig& config, const std::string& config_path,
                                 const std::filesystem::path& log, CalibrationMethod method,
                                 const CalibrationOptions& options = {});

}  // namespace moa::io
