// moa simulate: a scenario run through the simulator, written as a log
// (docs/formats/cli.md): log format v1 + robot.yaml (nominal) + robot.true.yaml.
#include <fmt/core.h>
#include <fmt/format.h>
#include <unistd.h>

#include <charconv>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <system_error>

#include "commands.hpp"
#include "moa/formats/error.hpp"
#include "moa/runs/output_path.hpp"
#include "moa/sim/log_writer.hpp"
#include "moa/sim/random_world.hpp"
#include "moa/sim/scenario.hpp"
#include "odometry_options.hpp"

namespace moa::cli {
namespace {

struct SimulateArgs {
  std::string scenario;
  std::optional<std::uint64_t> random;  ///< --random SEED: a drawn world, seed SEED
  std::string family = "any";
  std::uint64_t seed = 1;
  std::string out;
  bool quiet = false;
};

int run_simulate(const SimulateArgs& args) {
  // A random world is a scenario like any other; its text goes beside the
  // log (scenario.yaml) so that it can be replayed and edited.
  std::optional<sim::RandomWorld> world;
  if (args.random) {
    try {
      world = sim::random_scenario(*args.random, args.family);
    } catch (const std::invalid_argument& e) {
      throw io::Error(fmt::format("--family: {}", e.what()));
    }
  }
  const sim::Scenario scenario = world ? world->scenario : sim::load_scenario(args.scenario);
  const std::uint64_t seed = world ? *args.random : args.seed;
  // The log directory is replaced whole: it must not hold the scenario file.
  std::error_code ec;
  if (std::filesystem::is_regular_file(args.scenario, ec)) {
    io::refuse_output_onto_inputs(args.out, "--out", {args.scenario});
  }

  // A progress line only where someone watches (a terminal) and only once
  // the run has taken long enough to wonder about.
  const bool tty = !args.quiet && isatty(STDERR_FILENO);
  const auto start = std::chrono::steady_clock::now();
  auto last = start;
  bool shown = false;
  const auto progress = [&](double fraction) {
    if (!tty) return;
    const auto now = std::chrono::steady_clock::now();
    if (now - start < std::chrono::seconds(1) || now - last < std::chrono::milliseconds(250)) {
      return;
    }
    last = now;
    shown = true;
    fmt::print(stderr, "\rmoa simulate: {:3.0f}% of {:.1f} s simulated", 100.0 * fraction,
               scenario.duration);
  };
  const sim::LogSummary s = sim::write_log(scenario, seed, args.out, progress,
                                           world ? std::string_view(world->yaml) : "");
  if (shown) fmt::print(stderr, "\r\033[K");
  if (!args.quiet) {
    fmt::print(
        "moa simulate: scenario '{}', seed {}: {:.2f} s, {} sensors, {} mice rows ({} with a "
        "fault), {} wheel rows, {} camera fixes, {} truth rows; log written to {}\n",
        scenario.name, seed, s.duration, scenario.nominal.array.size(), s.mice_rows, s.faulty_rows,
        s.wheel_rows, s.camera_rows, s.truth_rows, args.out);
    if (world) {
      fmt::print("moa simulate: the world: {}\n", world->summary);
      for (const auto& u : scenario.unobservable) fmt::print("moa simulate: unobservable: {}\n", u);
    }
  }
  return 0;
}

std::string scenario_help() {
  std::string names;
  for (const auto& n : sim::builtin_scenarios()) names += (names.empty() ? "" : ", ") + n;
  return "A built-in scenario (" + names + ") or a scenario YAML file (docs/simulator.md)";
}

}  // namespace

CLI::Validator seed_check() {
  return CLI::Validator(
      [](const std::string& text) -> std::string {
        std::uint64_t value = 0;
        const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
        if (text.empty() || ec != std::errc{} || end != text.data() + text.size()) {
          return "'" + text + "' is not a whole number from 0 to 18446744073709551615";
        }
        return {};
      },
      "SEED");
}

void add_simulate(CLI::App& app, Action& action) {
  auto args = std::make_shared<SimulateArgs>();
  auto* cmd = app.add_subcommand(
      "simulate", "Simulate a scenario: a log with truth, robot.yaml and robot.true.yaml");
  auto* scenario = cmd->add_option("--scenario", args->scenario, scenario_help());
  auto* seed = cmd->add_option("--seed", args->seed,
                               "Random seed, a whole number from 0 to 2^64 - 1: the same seed "
                               "gives the same bytes")
                   ->capture_default_str()
                   ->check(seed_check());
  const std::string families = fmt::format("{}", fmt::join(sim::random_families(), ", "));
  auto* random = cmd->add_option("--random", args->random,
                                 "A random world instead of a scenario: robot, sensors, path, "
                                 "wheels, gyro, reference and faults drawn from SEED (the same "
                                 "SEED, the same world; its text is written to scenario.yaml)")
                     ->type_name("SEED")
                     ->check(seed_check())
                     ->excludes(scenario)
                     ->excludes(seed);
  cmd->add_option("--family", args->family,
                  "With --random: the family drawn from (" + families +
                      "; docs/simulator.md, \"Random worlds\")")
      ->capture_default_str()
      ->check(CLI::IsMember(sim::random_families()))
      ->needs(random);
  cmd->add_option("--out", args->out, "Output log directory (created if needed)")
      ->required()
      ->check(output_file_name());
  cmd->add_flag("--quiet", args->quiet, "Print nothing on success");
  cmd->callback([&action, args, scenario, random] {
    // A usage error (exit 2), as CLI11's own for a required option.
    if (scenario->count() == 0 && random->count() == 0) {
      throw CLI::RequiredError("--scenario (or --random)");
    }
    action = [args] { return run_simulate(*args); };
  });
}

}  // namespace moa::cli
