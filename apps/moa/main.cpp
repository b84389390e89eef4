// moa: robot velocity and pose from several optical mouse sensors.
#include <fmt/core.h>

#include <exception>

#include "commands.hpp"
#include "moa/io/cleanup.hpp"
#include "moa/io/error.hpp"

int main(int argc, char** argv) {
  // Ctrl-C or SIGTERM: no temporary file left behind, exit 130 or 143.
  moa::io::remove_temporaries_on_signal();
  CLI::App app{
      "moa: robot velocity and pose from an array of optical mouse sensors.\n"
      "Formats: robot config v1 (YAML), log format v1 (a directory of CSV files)."};
  app.require_subcommand(1);
  app.set_version_flag("--version", MOA_VERSION);
  moa::cli::Action action;
  moa::cli::add_version(app, action);
  moa::cli::add_odometry(app, action);
  moa::cli::add_evaluate(app, action);
  moa::cli::add_simulate(app, action);
  moa::cli::add_import_evemu(app, action);
  moa::cli::add_live(app, action);
  moa::cli::add_analyze(app, action);
  moa::cli::add_bench(app, action);
  moa::cli::add_report(app, action);
  moa::cli::add_calibrate(app, action);
  moa::cli::add_experiment(app, action);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    return action();
  } catch (const std::exception& e) {
    const auto* sub = app.get_subcommands().empty() ? nullptr : app.get_subcommands().front();
    fmt::print(stderr, "moa {}: error: {}\n", sub ? sub->get_name() : "", e.what());
    return 1;
  }
}
