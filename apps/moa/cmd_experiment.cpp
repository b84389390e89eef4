// moa experiment NAME [--json]: re-runs a published experiment
// (moa/experiments/experiment.hpp; docs/experiments.md).
#include <fmt/core.h>
#include <fmt/format.h>
#include <unistd.h>

#include <charconv>
#include <cstring>
#include <memory>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "commands.hpp"
#include "moa/experiments/experiment.hpp"
#include "moa/experiments/report.hpp"
#include "moa/formats/error.hpp"
#include "moa/sim/random_world.hpp"

namespace moa::cli {
namespace {

struct ExperimentArgs {
  std::string name;
  experiments::Options options;
  bool json = false;
  bool list = false;
  std::string report;  ///< --report FILE.html: the page of one run (experiments/report.hpp)
  std::string seeds;   ///< --seeds A-B (random)
  bool seed_given = false;
};

// "A-B" (or "A"): the first seed and the count, into options; a usage error
// names the flag.
void parse_seed_range(const std::string& text, experiments::Options& options) {
  const auto dash = text.find('-');
  const std::string a = text.substr(0, dash);
  const std::string b = dash == std::string::npos ? a : text.substr(dash + 1);
  std::uint64_t first = 0, last = 0;
  const auto whole = [](const std::string& s, std::uint64_t& v) {
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    return !s.empty() && ec == std::errc{} && end == s.data() + s.size();
  };
  if (!whole(a, first) || !whole(b, last) || last < first || last - first >= 1000000) {
    throw io::Error(fmt::format(
        "--seeds '{}': give A-B (or A), whole numbers with A <= B and at most 1000000 seeds",
        text));
  }
  options.seed = first;
  options.runs = static_cast<int>(last - first + 1);
}

std::string available() {
  std::vector<std::string> names;
  for (const auto& e : experiments::all()) names.emplace_back(e.name);
  return fmt::format("{}", fmt::join(names, ", "));
}

int run_experiment(ExperimentArgs args) {
  if (args.list || args.name.empty()) {
    if (!args.list) throw io::Error(fmt::format("which experiment? (available: {})", available()));
    for (const auto& e : experiments::all()) fmt::print("{:<20} {}\n", e.name, e.summary);
    return 0;
  }
  if (args.options.runs < 0)
    throw io::Error(fmt::format("--runs {}: must be >= 0", args.options.runs));
  const experiments::Experiment* e = experiments::find(args.name);
  if (!e) {
    throw io::Error(fmt::format("unknown experiment '{}' (available: {})", args.name, available()));
  }
  const bool random = std::string_view(e->name) == "random";
  if (!random && (!args.seeds.empty() || !args.options.family.empty())) {
    throw io::Error(fmt::format("{} is for `moa experiment random` only",
                                args.seeds.empty() ? "--family" : "--seeds"));
  }
  if (!args.seeds.empty()) {
    if (args.seed_given || args.options.runs != 0) {
      throw io::Error(fmt::format("--seeds and {} exclude each other: give the seeds as A-B",
                                  args.seed_given ? "--seed" : "--runs"));
    }
    parse_seed_range(args.seeds, args.options);
  }
  const experiments::ExperimentReportRecipe* recipe =
      experiments::experiment_report_recipe(e->name);
  if (!args.report.empty() && !recipe && !random) {
    throw io::Error(fmt::format("experiment '{}' has no report page (--report)", e->name));
  }
  const bool progress = isatty(STDERR_FILENO);
  if (progress) {
    args.options.progress = [](const std::string& status) {
      fmt::print(stderr, "\r\033[K{}", status);
    };
  }
  const experiments::Result result = e->run(args.options);
  if (progress) fmt::print(stderr, "\r\033[K");
  fmt::print("{}", args.json ? result.json : result.text);
  if (args.report.empty()) return 0;
  if (random) {
    // The page of the worst seed (the first of "worst"), else of the first seed.
    std::uint64_t seed = args.options.seed;
    const auto at = result.json.find("\"worst\": [{\"seed\": ");
    if (at != std::string::npos) {
      const char* first = result.json.data() + at + std::strlen("\"worst\": [{\"seed\": ");
      std::from_chars(first, result.json.data() + result.json.size(), seed);
    }
    experiments::write_random_report(
        seed, args.options.family.empty() ? "any" : args.options.family, args.report);
    if (!args.json) fmt::print("report of seed {} written to {}\n", seed, args.report);
    return 0;
  }
  experiments::write_experiment_report(*recipe, args.options.seed, args.report);
  if (!args.json) fmt::print("report written to {}\n", args.report);
  return 0;
}

}  // namespace

void add_experiment(CLI::App& app, Action& action) {
  auto args = std::make_shared<ExperimentArgs>();
  auto* cmd = app.add_subcommand(
      "experiment", "Re-run a published experiment and print the paper's figures beside ours");
  cmd->add_option("name", args->name, "Experiment name (see --list)");
  cmd->add_flag("--list", args->list, "List the experiments");
  cmd->add_flag("--json", args->json,
                "One JSON object on stdout, SI units; each run with the moa calls that reproduce "
                "it");
  cmd->add_option("--report", args->report,
                  "Also write the report page (HTML, docs/report.md) of one run of the "
                  "experiment's scenario, simulated with --seed (random: of its worst seed)");
  cmd->add_option("--seed", args->options.seed, "First seed; run k uses seed + k")
      ->check(seed_check())
      ->capture_default_str()
      ->each([args](const std::string&) { args->seed_given = true; });
  cmd->add_option("--runs", args->options.runs,
                  "Repetitions (Monte Carlo trials or runs); 0: the experiment's default")
      ->capture_default_str();
  std::vector<std::string> families;
  for (const auto& f : sim::random_families()) families.push_back(f);
  cmd->add_option("--family", args->options.family,
                  "random: the family of the worlds (" +
                      fmt::format("{}", fmt::join(families, ", ")) + "; default any)")
      ->check(CLI::IsMember(families));
  cmd->add_option("--seeds", args->seeds,
                  "random: the seeds A-B, or one seed A (tune on 1-9999, report from 10001); "
                  "default 20 from --seed")
      ->type_name("A-B");
  cmd->callback([&action, args] { action = [args] { return run_experiment(*args); }; });
}

}  // namespace moa::cli
