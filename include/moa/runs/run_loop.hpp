// The one run loop: rows pulled from a source (mice rows, wheel twists,
// camera fixes, already in the order they are to be fed) go through the
// odometry pipeline (moa/core/odometry.hpp), and each step to the caller's
// sink. `moa odometry` (a log's files, runs/odometry_run.hpp), `moa live`
// (a device, a replay, the robot's streams) and the experiments all run it,
// so a live run and the replay of its recording compute the same steps.
#pragma once

#include <array>
#include <cstddef>
#include <functional>
#include <string>
#include <variant>
#include <vector>

#include "moa/core/odometry.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/log.hpp"

#include "moa/runs/run_summary.hpp"

namespace moa::io {

/// One row of a run's input: a mice row, a wheel twist (robot frame, m/s
/// and rad/s, averaged over the interval ending at t), a camera fix (world
/// frame, m and rad) or a gyro rate (rad/s about z, averaged over the
/// interval ending at t).
using InputRow = std::variant<SensorRow, WheelRow, CameraFix, ImuRow>;

/// The time of a row (s).
double row_time(const InputRow& row);

/// Where a run's rows come from. The source merges its streams: every row
/// is handed out in the order the pipeline is to see it (a log: the fixes,
/// then the wheel rows, up to each mice row's time, then the mice row). The
/// stream ends with its last mice row: wheel rows and fixes after it are not
/// handed out.
class RunSource {
 public:
  virtual ~RunSource() = default;
  /// Time from which the first row of each sensor accumulates (s).
  virtual double start_time() = 0;
  /// The next row, valid until the next call; nullptr at the end. Throws
  /// io::Error on bad input, after the rows before it.
  virtual const InputRow* next() = 0;
  /// Where the row last handed out came from, for error messages: a file
  /// and line ("DIR/mice.csv:12"), a device, a stream.
  virtual std::string where() const = 0;
};

/// What the loop tells its caller as it goes. Every callback may be empty.
struct RunCallbacks {
  /// Every step of the pipeline. The step's pointers are valid during the
  /// call only.
  std::function<void(const OdometryStep&)> on_step;
  /// Every row the pipeline takes (a recording), once it has taken it.
  std::function<void(const InputRow&)> on_row;
  /// Set for a live input: a mice row the pipeline refuses (a saturated
  /// record, a time out of order, impossible counts) is handed here with the
  /// reason and skipped, not recorded, instead of ending the run.
  std::function<void(const SensorRow&, const std::string& why)> on_refused;
  /// Set for a live input: a wheel row, gyro row or camera fix the pipeline
  /// cannot hold (a burst: its stream's ring of rows kept ahead of the mice
  /// rows is full) is handed here with the reason and skipped, not
  /// recorded, instead of ending the run.
  std::function<void(const InputRow&, const std::string& why)> on_stream_full;
  /// Every 4096 mice rows: the mice rows so far and the last one's time (s).
  std::function<void(std::size_t rows, double t)> progress;
  /// A condition the run survives, one line without a newline, as it happens
  /// (a sensor whose self-calibration ran away). Also kept in the result.
  std::function<void(const std::string&)> warn;
};

/// What the run did.
struct OdometryRun {
  std::size_t rows = 0;          ///< mice rows fed
  std::size_t wheel_rows = 0;    ///< wheel rows fed
  std::size_t fix_rows = 0;      ///< camera fixes fed
  std::size_t imu_rows = 0;      ///< gyro rows fed
  std::size_t steps = 0;         ///< epochs written
  double t0 = 0.0, t_end = 0.0;  ///< s, first epoch's start, last mice row's time
  /// Mice rows per sensor of the config (index as in the config).
  std::array<std::size_t, kMaxSensors> rows_per_sensor{};
  /// Epochs by source, exclusions by reason, camera fixes, warnings (a
  /// configured sensor that never reported, used as still by a robust
  /// estimator; a self-calibration that ran away) and the verdict.
  RunSummary summary;
};

/// Runs the pipeline over `source` until it ends, then ends the stream at
/// the last mice row's time (Odometry::finish). Throws io::Error naming the
/// row's source and time for a row the pipeline refuses ("DIR/mice.csv:12:
/// row at t = 1.5 s: ..."), `config_path` for a geometry the estimator
/// refuses. A selected sensor that never reported is refused for least
/// squares and the oracle (they would take it as still; `source_name` names
/// the input in that message) and a warning for the robust estimators.
OdometryRun run_loop(const RobotConfig& config, const std::string& config_path,
                     const OdometryOptions& options, RunSource& source,
                     const std::string& source_name, const RunCallbacks& callbacks);

}  // namespace moa::io
