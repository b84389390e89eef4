// `moa experiment NAME`: a registry of re-runnable published experiments.
//
// To add one: a file apps/moa/exp_<name>.cpp (or any file of the CLI) with
// the function and ONE line that registers it at start-up:
//   const ExperimentRegistration kRegistered{"my-name", "what it re-runs", run_my_name};
// `moa experiment --list` shows them; `moa experiment my-name [--json]
// [--runs N] [--seed S]` runs one.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace moa::cli {

struct ExperimentOptions {
  bool json = false;       ///< one JSON object on stdout instead of text
  std::uint64_t seed = 1;  ///< for everything random in the experiment
  int runs = 0;            ///< repetitions (Monte Carlo trials, runs); 0: the experiment's default
};

/// Runs the experiment, prints its result, returns the exit code.
using ExperimentFunction = std::function<int(const ExperimentOptions&)>;

struct Experiment {
  std::string name;
  std::string summary;
  ExperimentFunction run;
};

/// Every registered experiment, sorted by name.
std::vector<Experiment> experiments();

/// Registers an experiment when the program starts (see above).
class ExperimentRegistration {
 public:
  ExperimentRegistration(std::string name, std::string summary, ExperimentFunction run);
};

}  // namespace moa::cli
