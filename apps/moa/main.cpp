// moa: robot velocity and pose from several optical mouse sensors.
#include <fmt/core.h>

#include <exception>
#include <string>
#include <string_view>

#include "commands.hpp"
#include "exit_codes.hpp"
#include "moa/formats/cleanup.hpp"
#include "moa/formats/error.hpp"
#include "odometry_options.hpp"

namespace {

constexpr const char* kFooter =
    "Exit codes: 0 success, 1 bad input (a malformed file, an invalid value, refused data),\n"
    "2 usage error (unknown command or option, missing argument), 3 a file that cannot be\n"
    "opened or written, 4 internal error (a bug: please report it), 130/143 interrupted\n"
    "(SIGINT/SIGTERM; no partial output is left).";

/// Every floating-point option of every subcommand refuses NaN and
/// infinities, naming the option (CLI11's ranges let NaN through).
void refuse_non_finite_numbers(CLI::App& app) {
  for (CLI::App* sub : app.get_subcommands({})) {
    for (CLI::Option* option : sub->get_options()) {
      if (option->get_type_name().find("FLOAT") != std::string::npos) {
        option->check(moa::cli::kFinite);
      }
    }
    refuse_non_finite_numbers(*sub);
  }
}

std::string subcommand_names(CLI::App& app) {
  std::string names;
  for (const CLI::App* sub : app.get_subcommands({})) {
    names += (names.empty() ? "" : ", ") + sub->get_name();
  }
  return names;
}

}  // namespace

int main(int argc, char** argv) {
  // Ctrl-C or SIGTERM: no temporary file left behind, exit 130 or 143.
  moa::io::remove_temporaries_on_signal();
  CLI::App app{
      "moa: robot velocity and pose from an array of optical mouse sensors.\n"
      "Formats: robot config v1 (YAML), log format v1 (a directory of CSV files)."};
  app.require_subcommand(1);
  app.set_version_flag("--version", MOA_VERSION);
  app.footer(kFooter);
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
  moa::cli::add_config(app, action);
  refuse_non_finite_numbers(app);

  // An unknown word where the command goes is named as such (CLI11 would
  // only say that a subcommand is required).
  const auto known = [&](std::string_view word) {
    for (const CLI::App* sub : app.get_subcommands({})) {
      if (sub->get_name() == word) return true;
    }
    return false;
  };
  if (argc > 1 && argv[1][0] != '-' && !known(argv[1])) {
    fmt::print(stderr, "moa: unknown command '{}' (commands: {}; moa --help)\n", argv[1],
               subcommand_names(app));
    return moa::cli::kExitUsage;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::RequiredError& e) {
    // An unknown option is the likelier mistake than the missing one it
    // makes: say that first.
    for (const CLI::App* sub : app.get_subcommands()) {
      const auto extras = sub->remaining();
      if (!extras.empty()) {
        fmt::print(stderr, "moa {}: unknown option or argument '{}' (moa {} --help)\n",
                   sub->get_name(), extras.front(), sub->get_name());
        return moa::cli::kExitUsage;
      }
    }
    app.exit(e);
    return moa::cli::kExitUsage;
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return moa::cli::kExitUsage;
  }
  // "config init": the chain of subcommands given, for the error line.
  std::string name;
  for (const CLI::App* sub = &app; !sub->get_subcommands().empty();) {
    sub = sub->get_subcommands().front();
    name += (name.empty() ? "" : " ") + sub->get_name();
  }
  try {
    return action();
  } catch (const moa::io::IoError& e) {
    fmt::print(stderr, "moa {}: error: {}\n", name, e.what());
    return moa::cli::kExitIo;
  } catch (const moa::io::Error& e) {
    fmt::print(stderr, "moa {}: error: {}\n", name, e.what());
    return moa::cli::kExitBadInput;
  } catch (const std::exception& e) {
    fmt::print(stderr, "moa {}: internal error: {}\n", name, e.what());
    return moa::cli::kExitInternal;
  }
}
