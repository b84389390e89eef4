// `moa bench --replay`: `moa odometry` (io::write_odometry, with its reader
// and writer threads) over a long generated log, against a plain parse of
// the same mice.csv, in one process (docs/performance.md). The CLI prints
// the result.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

namespace moa::bench {

struct ReplayBenchOptions {
  double duration = 600.0;     ///< s of log
  double row_rate = 1000.0;    ///< rows per second per sensor
  double epoch_rate = 1000.0;  ///< Hz, the replay's epoch rate
  std::string estimator = "consensus";
  int repeats = 3;            ///< best of
  std::filesystem::path dir;  ///< where the temporary log goes (system temp if empty)
  bool keep_log = false;      ///< leave the log (and odometry.csv) for runs of `moa odometry`
};

/// Best of the repeats, of one pass.
struct Timing {
  double wall = 1e300;    ///< s
  double cpu = 1e300;     ///< s of process CPU time (all threads)
  double thread = 1e300;  ///< s of CPU time of the calling thread: the pipeline's
};

struct ReplayBenchResult {
  double duration = 0.0;          ///< s of log
  std::size_t rows = 0;           ///< mice rows of the log (four sensors)
  std::uintmax_t mice_bytes = 0;  ///< bytes of mice.csv
  std::size_t epochs = 0;         ///< odometry steps written
  std::uintmax_t odometry_bytes = 0;
  Timing parse, replay;             ///< parse-only pass; the replay
  std::filesystem::path log_dir;    ///< where the log was (removed unless keep_log)
  double real_time_factor() const;  ///< s of log per s of replay (wall)
};

/// Writes the log (four sensors, noise-free counts of a smooth drive),
/// times both passes `repeats` times and removes the log unless kept.
/// `progress` gets one line at each stage ("writing a 600 s log ...").
/// Throws std::invalid_argument for an estimator that is not ls, sekimori or
/// consensus (the log has no wheels and no faults).
ReplayBenchResult run_replay_bench(const ReplayBenchOptions& options,
                                   const std::function<void(const std::string&)>& progress = {});

}  // namespace moa::bench
