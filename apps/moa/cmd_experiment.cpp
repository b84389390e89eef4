// moa experiment NAME [--json]: re-runs a published experiment (spec/cli.md).
#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "experiment_report.hpp"
#include "experiments.hpp"
#include "moa/io/error.hpp"

namespace moa::cli {

namespace {

// Function-local so that registrations from other files' static
// initialisers find it constructed whatever the initialisation order.
std::vector<Experiment>& registry() {
  static std::vector<Experiment> all;
  return all;
}

struct ExperimentArgs {
  std::string name;
  ExperimentOptions options;
  bool list = false;
  std::string report;  ///< --report FILE.html: the page of one run (experiment_report.hpp)
};

std::string available() {
  std::vector<std::string> names;
  for (const auto& e : experiments()) names.push_back(e.name);
  return fmt::format("{}", fmt::join(names, ", "));
}

int run_experiment(const ExperimentArgs& args) {
  if (args.list || args.name.empty()) {
    if (!args.list) throw io::Error(fmt::format("which experiment? (available: {})", available()));
    for (const auto& e : experiments()) fmt::print("{:<20} {}\n", e.name, e.summary);
    return 0;
  }
  if (args.options.runs < 0)
    throw io::Error(fmt::format("--runs {}: must be >= 0", args.options.runs));
  for (const auto& e : experiments()) {
    if (e.name != args.name) continue;
    const ExperimentReportRecipe* recipe = experiment_report_recipe(e.name);
    if (!args.report.empty() && !recipe) {
      throw io::Error(fmt::format("experiment '{}' has no report page (--report)", e.name));
    }
    const int code = e.run(args.options);
    if (code != 0 || args.report.empty()) return code;
    write_experiment_report(*recipe, args.options.seed, args.report);
    if (!args.options.json) fmt::print("report written to {}\n", args.report);
    return 0;
  }
  throw io::Error(fmt::format("unknown experiment '{}' (available: {})", args.name, available()));
}

}  // namespace

std::vector<Experiment> experiments() {
  std::vector<Experiment> out = registry();
  std::sort(out.begin(), out.end(),
            [](const Experiment& a, const Experiment& b) { return a.name < b.name; });
  return out;
}

ExperimentRegistration::ExperimentRegistration(std::string name, std::string summary,
                                               ExperimentFunction run) {
  registry().push_back({std::move(name), std::move(summary), std::move(run)});
}

void add_experiment(CLI::App& app, Action& action) {
  auto args = std::make_shared<ExperimentArgs>();
  auto* cmd = app.add_subcommand(
      "experiment", "Re-run a published experiment and print the paper's figures beside ours");
  cmd->add_option("name", args->name, "Experiment name (see --list)");
  cmd->add_flag("--list", args->list, "List the experiments");
  cmd->add_flag("--json", args->options.json, "One JSON object on stdout, SI units");
  cmd->add_option("--report", args->report,
                  "Also write the report page (HTML, docs/report.md) of one run of the "
                  "experiment's scenario, simulated with --seed");
  cmd->add_option("--seed", args->options.seed, "Seed of everything random")->capture_default_str();
  cmd->add_option("--runs", args->options.runs,
                  "Repetitions (Monte Carlo trials or runs); 0: the experiment's default")
      ->capture_default_str();
  cmd->callback([&action, args] { action = [args] { return run_experiment(*args); }; });
}

}  // namespace moa::cli
