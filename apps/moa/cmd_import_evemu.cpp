// moa import-evemu: evemu recordings of mice -> a log v1 (mice.csv).
//
// Every count is kept: per sensor, the sums of dx and dy in mice.csv equal
// the sums of REL_X and REL_Y in its recording (see io/evemu.hpp).
#include <fmt/core.h>

#include <filesystem>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "commands.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/mice_writer.hpp"
#include "moa/runs/output_path.hpp"
#include "moa/sources/evemu.hpp"
#include "sensor_binding.hpp"

namespace moa::cli {
namespace {

/// s between recordings beyond which they were not made together.
constexpr double kApartWarning = 60.0;

struct ImportEvemuArgs {
  std::vector<std::string> sensors;
  std::string out;
  bool quiet = false;
};

int run_import_evemu(const ImportEvemuArgs& args) {
  std::vector<io::EvemuInput> inputs;
  std::vector<std::string> names;
  for (const auto& binding : parse_bindings(args.sensors, "--sensor")) {
    inputs.push_back({binding.name, binding.target});
    names.push_back(binding.name);
  }
  std::vector<std::filesystem::path> recordings;
  for (const auto& in : inputs) recordings.push_back(in.file);
  io::refuse_output_onto_inputs(std::filesystem::path(args.out) / "mice.csv", "--out", recordings);
  io::EvemuReader reader(inputs);

  std::vector<std::string> comments{
      "imported by moa import-evemu; t: s after the earliest event over all recordings; "
      "dx, dy: raw REL_X, REL_Y counts"};
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    const auto& stats = reader.stats(static_cast<int>(i));
    comments.push_back(
        fmt::format("sensor {}: {} (device '{}')", names[i], stats.events.string(), stats.device));
  }
  const std::filesystem::path dir(args.out);
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw io::Error(fmt::format("{}: cannot create directory ({})", args.out, ec.message()));
  io::MiceWriter writer(dir / "mice.csv", names, false, io::MiceWriter::Durability::kWholeOrNothing,
                        comments);
  // Each recording's span of rows (s), to tell recordings made apart.
  std::vector<std::pair<double, double>> span(inputs.size(), {0.0, -1.0});
  while (const auto row = reader.next()) {
    writer.write(*row);
    auto& [first, last] = span[static_cast<std::size_t>(row->sensor)];
    if (last < first) first = row->t;
    last = row->t;
  }
  writer.commit();
  // Rows are timed from the earliest event of all recordings: recordings
  // made at different times leave a silence that `moa odometry` fills with
  // still epochs (and refuses beyond --max-gap).
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    for (std::size_t j = 0; j < inputs.size(); ++j) {
      const double apart = span[j].first - span[i].second;
      if (i != j && span[i].second >= span[i].first && span[j].second >= span[j].first &&
          apart > kApartWarning) {
        fmt::print(stderr,
                   "moa import-evemu: warning: {} starts {:.0f} s after {} ends: recordings of "
                   "one run should overlap in time\n",
                   names[j], apart, names[i]);
      }
    }
  }

  for (std::size_t i = 0; i < inputs.size(); ++i) {
    const auto& stats = reader.stats(static_cast<int>(i));
    if (stats.dropped > 0) {
      fmt::print(stderr,
                 "moa import-evemu: warning: {}: {} SYN_DROPPED events: the kernel dropped "
                 "events while recording, their counts are not in the file\n",
                 stats.events.string(), stats.dropped);
    }
    if (stats.unterminated) {
      fmt::print(stderr,
                 "moa import-evemu: warning: {}: ends inside a frame (no final SYN_REPORT); its "
                 "counts are kept\n",
                 stats.events.string());
    }
    if (!args.quiet) {
      fmt::print("{}: {} frames with motion, sum dx {}, sum dy {} ({} events, device '{}')\n",
                 names[i], stats.frames, stats.sum_dx, stats.sum_dy, stats.events_read,
                 stats.device);
    }
  }
  if (!args.quiet)
    fmt::print("moa import-evemu: {} rows written to {}\n", writer.rows(),
               (dir / "mice.csv").string());
  return 0;
}

}  // namespace

void add_import_evemu(CLI::App& app, Action& action) {
  auto args = std::make_shared<ImportEvemuArgs>();
  auto* cmd = app.add_subcommand(
      "import-evemu", "evemu-record files of mice -> log v1 (mice.csv), every count kept");
  cmd->add_option("--sensor", args->sensors,
                  "NAME=FILE: the recording of sensor NAME: new style (one file with a "
                  "'# EVEMU' header) or old style (FILE.events, FILE.desc or their common stem); "
                  "repeat per sensor")
      ->required()
      ->take_all();
  cmd->add_option("--out", args->out, "Log directory to write (created if needed)")->required();
  cmd->add_flag("--quiet", args->quiet, "Print nothing on success");
  cmd->callback([&action, args] { action = [args] { return run_import_evemu(*args); }; });
}

}  // namespace moa::cli
