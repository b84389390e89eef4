// The papers' experiments as a library module: `moa experiment NAME`, the
// tests and the Python bindings run them from here. Each returns its text
// and its JSON; the caller prints.
//
// JSON of every experiment: {"experiment", "runs", "seeds", "rows": [...]};
// a row has its labels, its figures (means over the runs, SI units) and, for
// the methods run through the odometry pipeline, "runs": one object per run
// with its seed, its figures and "reproduce": the moa calls that recompute
// them ($OUT a scratch directory; the last call is `moa evaluate --json`).
// self-calibration also has "scale": per scenario the affected sensor's true
// and estimated scale at each sample time, and each run's estimates.
// random (random_worlds.cpp) has its own stable form, docs/formats/random.md.
// gyro's rows are per case and method; the gyro-alone rows' runs have no
// reproduce (no moa call integrates imu.csv alone) but the bias they used,
// and a row the estimator refused has "refused" (its error) instead of figures.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <span>
#include <string>
#include <string_view>

namespace moa::experiments {

struct Options {
  /// First seed; run k uses seed + k. The thresholds were tuned on seeds
  /// 1-100 (core/noise_model.hpp), the tests use 101-200, the docs 201 on.
  std::uint64_t seed = 201;
  int runs = 0;  ///< repetitions; 0: the experiment's default
  /// `random` only: the family of the worlds (sim/random_world.hpp), "" for `any`.
  std::string family;
  /// Called with a short status ("table 4, speed (b): run 3/10").
  std::function<void(const std::string&)> progress;
};

struct Result {
  std::string text;  ///< the table a person reads, with its conclusions
  std::string json;  ///< one JSON object
};

struct Experiment {
  const char* name;
  const char* summary;
  Result (*run)(const Options& options);
};

/// `moa experiment random --report FILE.html`: the report page (docs/report.md)
/// of the world of `seed` in `family`, the default estimator against its
/// truth (the bench's worst seed, or --seed's). Throws io::Error.
void write_random_report(std::uint64_t seed, const std::string& family,
                         const std::filesystem::path& out);

/// Every experiment, sorted by name.
std::span<const Experiment> all();
/// The experiment called `name`, nullptr if none.
const Experiment* find(std::string_view name);

}  // namespace moa::experiments
