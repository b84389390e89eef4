// `moa experiment NAME --report FILE.html`: the report page (docs/report.md)
// of one representative run of an experiment: its scenario simulated with
// the experiment's seed, dead reckoning as `moa odometry` does it, truth.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string_view>

namespace moa::experiments {

struct ExperimentReportRecipe {
  const char* experiment;  ///< registered experiment name
  const char* scenario;    ///< built-in scenario of the run shown
  const char* estimator;   ///< ls | sekimori | consensus
  bool fuse_camera;        ///< EKF with the scenario's camera fixes
  /// Online self-calibration (`--self-calibrate`); the page plots its
  /// estimated scales over time.
  bool self_calibrate = false;
};

/// The recipe of an experiment that has a report; nullptr if it has none.
const ExperimentReportRecipe* experiment_report_recipe(std::string_view experiment);

/// Simulates the recipe's scenario with `seed` into a temporary directory,
/// runs the odometry pipeline on it, writes the page to `out` (atomically)
/// and removes the temporary directory. Throws io::Error.
void write_experiment_report(const ExperimentReportRecipe& recipe, std::uint64_t seed,
                             const std::filesystem::path& out);

}  // namespace moa::experiments
