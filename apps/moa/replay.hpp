// Replays an in-memory simulation through moa's estimators, for the
// papers' experiments: the same synchroniser, estimators, dead reckoning
// and filter as `moa odometry`, without files.
#pragma once

#include <string>

#include "moa/analysis/evaluate.hpp"
#include "moa/io/config.hpp"
#include "moa/sim/simulate.hpp"

namespace moa::cli {

enum class ReplayMethod {
  kWheels,     ///< wheel odometry alone
  kLs,         ///< least squares over `mask`, no selection
  kSekimori,   ///< Sekimori & Miyazaki voting, wheels as fallback
  kConsensus,  ///< consensus, wheels as fallback and plausibility check
  kOracle,     ///< least squares over the sensors without a fault (simulator truth)
};

struct ReplayOptions {
  ReplayMethod method = ReplayMethod::kConsensus;
  SensorMask mask = ~SensorMask{0};  ///< sensors available to the method
  double rate = 100.0;               ///< Hz, epochs
  bool fuse_camera = false;          ///< EKF with the simulated camera fixes
};

/// Errors of the replayed trajectory against the simulation's truth.
TrajectoryError replay(const sim::SimLog& log, const io::RobotConfig& config,
                       const ReplayOptions& options);

}  // namespace moa::cli
