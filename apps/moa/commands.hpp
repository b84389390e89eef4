// The moa command's subcommands: each file registers one on the CLI11 app
// and returns the action to run after parsing.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace moa::cli {

/// Runs the parsed subcommand; returns the process exit code.
using Action = std::function<int()>;

void add_version(CLI::App& app, Action& action);
void add_odometry(CLI::App& app, Action& action);
void add_evaluate(CLI::App& app, Action& action);
void add_simulate(CLI::App& app, Action& action);
void add_import_evemu(CLI::App& app, Action& action);
void add_live(CLI::App& app, Action& action);
void add_analyze(CLI::App& app, Action& action);
void add_bench(CLI::App& app, Action& action);
void add_report(CLI::App& app, Action& action);
void add_calibrate(CLI::App& app, Action& action);
void add_experiment(CLI::App& app, Action& action);
void add_config(CLI::App& app, Action& action);

/// --seed: digits only, 0 to 2^64 - 1 (CLI11 alone reads "-1" and "1e23"
/// as 2^64 - 1). Defined in cmd_simulate.cpp.
CLI::Validator seed_check();

}  // namespace moa::cli
