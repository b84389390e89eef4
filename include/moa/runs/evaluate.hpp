// `moa evaluate` on files: an odometry.csv (or any CSV beginning t,x,y,theta)
// against truth.csv. The experiments compute their figures with this same
// function, so `moa evaluate --json` reproduces them exactly.
#pragma once

#include <filesystem>

#include "moa/analysis/evaluate.hpp"

namespace moa::io {

/// Throws io::Error when truth has fewer than two rows or no estimate lies
/// within its time span.
TrajectoryError evaluate_files(const std::filesystem::path& truth,
                               const std::filesystem::path& odometry);

}  // namespace moa::io
