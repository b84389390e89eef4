// moa evaluate: max and RMS translation and heading error against truth,
// the distance travelled, and a verdict against a reference where there is one.
#include <fmt/core.h>

#include <cmath>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "commands.hpp"
#include "moa/analysis/evaluate.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/json.hpp"
#include "moa/formats/log.hpp"
#include "moa/runs/evaluate.hpp"

namespace moa::cli {
namespace {

struct EvaluateArgs {
  std::string truth;
  std::string odometry;
  std::string config;
  std::optional<double> reference_mm;
  std::string reference_label = "the reference";
  bool json = false;
};

int run_evaluate(const EvaluateArgs& args) {
  if (args.reference_mm && !(std::isfinite(*args.reference_mm) && *args.reference_mm > 0.0)) {
    throw io::Error(fmt::format("--reference-mm {}: must be a positive number of millimetres",
                                *args.reference_mm));
  }
  const TrajectoryError e = io::evaluate_files(args.truth, args.odometry);

  std::vector<ErrorReference> references;
  if (!args.config.empty()) {
    std::vector<StampedPose> truth;
    for (const auto& row : io::read_all<io::TruthRow>(args.truth)) {
      truth.push_back({row.t, row.pose});
    }
    const auto floor = quantisation_floor(io::read_config(args.config).array, truth);
    if (!floor) {
      throw io::Error(fmt::format("{}: its sensors cannot give a twist on the path of {}",
                                  args.config, args.truth));
    }
    references.push_back({floor->max_translation, "the quantisation floor", true});
  }
  if (args.reference_mm) references.push_back({*args.reference_mm * 1e-3, args.reference_label});

  if (args.json) {
    // Shortest round-trip numbers: the experiments' figures read back exactly.
    io::JsonWriter json;
    json.begin_object();
    for_each_member(e, [&json](const char* name, const auto& value) { json.member(name, value); });
    if (!references.empty()) {
      json.key("references").begin_array();
      for (const ErrorReference& r : references) {
        json.begin_object()
            .member("label", std::string_view(r.label))
            .member("max_translation_m", r.max_translation)
            .member("verdict", std::string_view(verdict(e, r)))
            .end_object();
      }
      json.end_array();
    }
    json.end_object();
    fmt::print("{}\n", json.str());
    return 0;
  }
  fmt::print("samples compared        {}\n", e.samples);
  if (e.outside > 0) fmt::print("outside the truth's span {} (not compared)\n", e.outside);
  fmt::print("translation error       {}\n", describe_translation(e));
  fmt::print("heading error           max {:.3g} deg, rms {:.3g} deg\n", to_degrees(e.max_heading),
             to_degrees(e.rms_heading));
  for (const ErrorReference& r : references)
    fmt::print("verdict                 {}\n", verdict(e, r));
  return 0;
}

}  // namespace

void add_evaluate(CLI::App& app, Action& action) {
  auto args = std::make_shared<EvaluateArgs>();
  auto* cmd = app.add_subcommand(
      "evaluate",
      "Max and RMS translation (mm) and heading (deg) error against truth, the distance "
      "travelled, and a verdict against the quantisation floor (--config) or a given figure");
  cmd->add_option("--truth", args->truth, "truth.csv (t,x,y,theta)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--odometry", args->odometry, "odometry.csv written by moa odometry")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--config", args->config,
                  "robot.yaml of the run: judge the error against the quantisation floor, the "
                  "error rounding to whole counts alone gives on the truth's path")
      ->check(CLI::ExistingFile);
  cmd->add_option("--reference-mm", args->reference_mm,
                  "A max translation error (mm) to judge the run against, e.g. a paper's");
  cmd->add_option("--reference-label", args->reference_label,
                  "What --reference-mm is, e.g. \"Sekimori & Miyazaki's Table 4\"")
      ->needs("--reference-mm");
  cmd->add_flag("--json", args->json,
                "One JSON object on stdout, SI units (m, rad), with distance_m and the "
                "references' verdicts");
  cmd->callback([&action, args] { action = [args] { return run_evaluate(*args); }; });
}

}  // namespace moa::cli
