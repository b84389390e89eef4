// moa evaluate: max and RMS translation and heading error against truth.
#include <fmt/core.h>

#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "moa/analysis/evaluate.hpp"
#include "moa/io/error.hpp"
#include "moa/io/log.hpp"

namespace moa::cli {
namespace {

struct EvaluateArgs {
  std::string truth;
  std::string odometry;
  bool json = false;
};

int run_evaluate(const EvaluateArgs& args) {
  std::vector<StampedPose> truth;
  for (const auto& row : io::read_all<io::TruthRow>(args.truth)) truth.push_back({row.t, row.pose});
  if (truth.size() < 2) throw io::Error(fmt::format("{}: needs at least two rows", args.truth));

  // odometry.csv begins with t,x,y,theta: the truth reader reads exactly those.
  io::TruthReader odometry(args.odometry);
  TrajectoryErrorAccumulator acc(truth);
  while (const auto row = odometry.next()) acc.add(row->t, row->pose);
  const TrajectoryError e = acc.result();
  if (e.samples == 0) {
    throw io::Error(
        fmt::format("{}: no row lies within the time span of {}", args.odometry, args.truth));
  }
  if (args.json) {
    fmt::print(
        "{{\"samples\": {}, \"outside_truth_span\": {}, \"max_translation_m\": {:.9g}, "
        "\"rms_translation_m\": {:.9g}, \"max_heading_rad\": {:.9g}, \"rms_heading_rad\": "
        "{:.9g}}}\n",
        e.samples, e.outside, e.max_translation, e.rms_translation, e.max_heading, e.rms_heading);
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
