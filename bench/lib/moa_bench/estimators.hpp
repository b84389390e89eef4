// `moa bench`: the median cost per update of moa's estimators against the
// literal formulations (baselines.hpp), all in one process so that the
// ratios are fair. The CLI prints the rows.
#pragma once

#include <string>
#include <vector>

namespace moa::bench {

struct EstimatorBenchOptions {
  int batches = 31;                 ///< timed batches per estimator (the median is reported)
  int updates = 2000;               ///< updates per batch
  std::vector<int> sizes{2, 4, 8};  ///< numbers of sensors, 2..kMaxSensors
};

/// Median over the batches of the time per update (ns), for N sensors
/// radial around the robot (Sekimori & Miyazaki's layout, HDNS-2051) on
/// 100 Hz samples of random motion, one in ten with a sensor that lost track.
struct EstimatorCosts {
  int n = 0;
  double ls = 0, naive_ls = 0, sekimori = 0, naive_sekimori = 0, consensus = 0;
};

/// One row per size, in the order of options.sizes. `progress` is called
/// with N before each size.
std::vector<EstimatorCosts> bench_estimators(const EstimatorBenchOptions& options,
                                             void (*progress)(int n) = nullptr);

/// The CPU's model name (/proc/cpuinfo), "unknown" if not found.
std::string cpu_model();

}  // namespace moa::bench
