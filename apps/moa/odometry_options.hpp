// The odometry pipeline's options on the command line, shared by
// `moa odometry` and `moa live`: one set of flags, one validation.
#pragma once

#include <CLI/CLI.hpp>
#include <optional>
#include <string>
#include <vector>

#include "moa/core/odometry.hpp"
#include "moa/formats/config.hpp"

namespace moa::cli {

/// A CLI11 check that refuses NaN and infinities ("--rate: nan is not a
/// finite number"): CLI11's ranges let NaN through.
extern const CLI::Validator kFinite;
/// A finite number within [lo, hi] (`lo` excluded when `open_low`), its
/// message short and first: "inf is not a finite number", "0: must be > 0",
/// "20000: must be within [0.1, 10000]" (CLI11's own ranges print
/// 1.797...e308 in full and add "AND" to kFinite's message).
CLI::Validator finite_within(double lo, double hi, bool open_low = false, bool open_high = false);
/// finite_within(0, inf, open): a positive number.
extern const CLI::Validator kPositive;
/// finite_within(0, inf): zero or more.
extern const CLI::Validator kNonNegative;
/// An output file or directory name: not "" (nothing would be written) nor
/// an option taken for a file name (--self-calibration --quiet).
CLI::Validator output_file_name();
/// output_file_name() for an output that is one file: not a name ending in
/// '/' nor an existing directory (their error was the system's "Not a
/// directory" at the end of the run).
CLI::Validator output_file();
/// output_file(), or "-" for standard output.
CLI::Validator output_file_or_stdout();

struct OdometryFlags {
  std::string estimator = "consensus";
  std::vector<std::string> sensors;  ///< as given, each NAME[,NAME...]; empty: all
  std::vector<double> initial_pose;  ///< x, y, theta
  bool no_wheels = false;
  bool no_imu = false;
  bool no_motion_prior = false;
  bool self_calibrate = false;
  std::string self_calibration_out;  ///< --self-calibration FILE.csv
  std::string diagnostics_out;       ///< --diagnostics FILE.csv
  /// --self-calibration-gauge sensors|wheels; empty: not given (sensors)
  std::string self_calibration_gauge;
  /// --max-row-interval; not given: OdometryOptions' 0.05 s, or 60 epochs
  /// where that is shorter (above 1200 Hz: the synchroniser's ring holds 61)
  std::optional<double> max_row_interval;
  OdometryOptions options;
};

/// Adds the pipeline's flags to `cmd`; `live` leaves out what needs a log
/// (camera fusion, the oracle).
void add_odometry_flags(CLI::App* cmd, OdometryFlags& flags, bool live = false);

/// The options for `config`: estimator and sensor names resolved, options
/// validated. Throws io::Error naming the flag.
/// What --self-calibrate cannot do with these options, one line each (empty
/// when it can): the wheels estimator uses no mice; fewer than three
/// selected sensors leave no redundancy to learn from.
std::vector<std::string> self_calibration_warnings(const OdometryOptions& options);

OdometryOptions resolve_odometry_flags(const OdometryFlags& flags, const io::RobotConfig& config,
                                       const std::string& config_path);

}  // namespace moa::cli
