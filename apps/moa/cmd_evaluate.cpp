// moa evaluate: max and RMS translation and heading error against truth.
#include <fmt/core.h>

#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "moa/analysis/evaluate.hpp"
#include "moa/io/error.hpp"
#include "moa/io/evaluate.hpp"
#include "moa/io/json.hpp"

namespace moa::cli {
namespace {

struct EvaluateArgs {
  std::string truth;
  std::string odometry;
  bool json = false;
};

int run_evaluate(const EvaluateArgs& args) {
  const TrajectoryError e = io::evaluate_files(args.truth, args.odometry);
  if (args.json) {
    // Shortest round-trip numbers: the experiments' figures read back exactly.
    io::JsonWriter json;
    json.begin_object()
        .member("samples", e.samples)
        .member("outside_truth_span", e.outside)
        .member("max_translation_m", e.max_translation)
        .member("rms_translation_m", e.rms_translation)
        .member("max_heading_rad", e.max_heading)
        .member("rms_heading_rad", e.rms_heading)
        .end_object();
    fmt::print("{}\n", json.str());
  } else {
    fmt::print("samples compared         {}\n", e.samples);
    if (e.outside > 0) fmt::print("outside the truth's span {} (not compared)\n", e.outside);
    fmt::print("translation error (m)    max {:.9g}  rms {:.9g}\n", e.max_translation,
               e.rms_translation);
    fmt::print("heading error (rad)      max {:.9g}  rms {:.9g}\n", e.max_heading, e.rms_heading);
  }
  return 0;
}

}  // namespace

void add_evaluate(CLI::App& app, Action& action) {
  auto args = std::make_shared<EvaluateArgs>();
  auto* cmd = app.add_subcommand(
      "evaluate", "Max and RMS translation (m) and heading (rad) error against truth");
  cmd->add_option("--truth", args->truth, "truth.csv (t,x,y,theta)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--odometry", args->odometry, "odometry.csv written by moa odometry")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_flag("--json", args->json, "One JSON object on stdout, SI units");
  cmd->callback([&action, args] { action = [args] { return run_evaluate(*args); }; });
}

}  // namespace moa::cli
