// moa bench --replay: `moa odometry` over a long log against a plain parse
// of the same mice.csv, in one process (docs/performance.md).
#pragma once

#include <filesystem>
#include <string>

namespace moa::cli {

struct ReplayBenchArgs {
  double duration = 600.0;     ///< s of log
  double row_rate = 1000.0;    ///< rows per second per sensor
  double epoch_rate = 1000.0;  ///< Hz, --rate of the replay
  std::string estimator = "consensus";
  int repeats = 3;            ///< best of
  std::filesystem::path dir;  ///< where the temporary log goes (system temp if empty)
  bool keep_log = false;      ///< leave the log (and odometry.csv) for runs of `moa odometry`
  bool json = false;
};

int run_replay_bench(const ReplayBenchArgs& args);

}  // namespace moa::cli
