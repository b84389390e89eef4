// moa live: odometry from devices as they stream, optionally recorded.
//
// Data path: EvdevReader, SerialReader or ReplayReader (rows; live_source.hpp)
// -> the same pipeline as `moa odometry` -> odometry rows (file or stdout), a
// status line and, with --serve, the dashboard (io/dashboard.hpp).
// Recording: every row the pipeline sees goes to DIR/mice.csv, starting with
// a zero row per sensor at the start time so that the log's clock starts
// where the live run's did; `moa odometry --config DIR/robot.yaml --log DIR`
// then reproduces the live odometry exactly (same rows, same t0, times
// written as shortest round-trip text).
//
// Ctrl-C (SIGINT) or SIGTERM ends the run between rows: the pipeline is
// flushed and every file committed. Rows reach DIR/mice.csv.part at least
// every status tick, so even a killed run leaves its recording there.
#include <fmt/core.h>
#include <fmt/format.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "commands.hpp"
#include "live_source.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/log.hpp"
#include "moa/formats/mice_writer.hpp"
#include "moa/formats/odometry_csv.hpp"
#include "moa/formats/self_calibration_csv.hpp"
#include "moa/runs/odometry_run.hpp"
#include "moa/runs/output_path.hpp"
#include "moa/runs/run_summary.hpp"
#include "moa/web/dashboard.hpp"
#include "odometry_options.hpp"
#include "sensor_binding.hpp"

namespace moa::cli {
namespace {

volatile std::sig_atomic_t g_stop = 0;

extern "C" void on_stop_signal(int) {
  // A second Ctrl-C means "now": the recording's .part file keeps what was
  // flushed.
  if (g_stop) _exit(130);
  g_stop = 1;
}

// Installs the handlers for the run and puts the old ones back afterwards.
// No SA_RESTART: poll() returns at once with EINTR.
class StopSignals {
 public:
  StopSignals() {
    g_stop = 0;
    struct sigaction action {};
    action.sa_handler = on_stop_signal;
    sigemptyset(&action.sa_mask);
    sigaction(SIGINT, &action, &old_int_);
    sigaction(SIGTERM, &action, &old_term_);
  }
  ~StopSignals() {
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
  }
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;

 private:
  struct sigaction old_int_ {};
  struct sigaction old_term_ {};
};

struct LiveArgs {
  std::string config;
  SourceFlags source;
  std::string record;
  std::string out;
  std::string serve;
  OdometryFlags odometry;
  double duration = 0.0;
  bool quiet = false;
};

// Rows per second over the last few seconds, for the status line.
class RateMeter {
 public:
  void add(std::size_t rows) { total_ += rows; }
  double rate(std::chrono::steady_clock::time_point now) {
    marks_.emplace_back(now, total_);
    while (marks_.size() > 2 && now - marks_.front().first > std::chrono::seconds(3)) {
      marks_.pop_front();
    }
    const double span = std::chrono::duration<double>(now - marks_.front().first).count();
    return span > 0 ? static_cast<double>(total_ - marks_.front().second) / span : 0.0;
  }

 private:
  std::size_t total_ = 0;
  std::deque<std::pair<std::chrono::steady_clock::time_point, std::size_t>> marks_;
};

int run_live(LiveArgs args) {
  namespace fs = std::filesystem;
  const io::RobotConfig config = io::read_config(args.config);
  const OdometryOptions odometry_options =
      resolve_odometry_flags(args.odometry, config, args.config);
  for (const auto& w : self_calibration_warnings(odometry_options)) {
    fmt::print(stderr, "moa live: warning: {}\n", w);
  }
  const bool status = !args.quiet && isatty(STDERR_FILENO);
  const bool to_stdout = args.out == "-";
  const auto started = std::chrono::steady_clock::now();
  StopSignals signals;

  // Shared by the hooks and the loop below.
  bool status_shown = false;
  std::function<void()> show_status;
  io::LiveHooks hooks;
  hooks.stop = [&] {
    return g_stop != 0 || (args.duration > 0 && std::chrono::steady_clock::now() - started >=
                                                    std::chrono::duration<double>(args.duration));
  };
  hooks.warn = [&](const std::string& text) {
    if (status_shown) fmt::print(stderr, "\r\033[K");
    fmt::print(stderr, "moa live: warning: {}\n", text);
  };
  hooks.tick = [&] {
    if (show_status) show_status();
  };

  // No output names an input (nor another output).
  std::vector<fs::path> inputs = source_files(args.source);
  inputs.emplace_back(args.config);
  if (!args.record.empty()) {
    const fs::path dir(args.record);
    io::refuse_output_onto_inputs(dir / "mice.csv", "--record", inputs);
    io::refuse_output_onto_inputs(dir / "robot.yaml", "--record", inputs);
  }
  if (!args.out.empty() && !to_stdout) {
    io::refuse_output_onto_inputs(args.out, "--out", inputs);
    if (!args.record.empty()) {
      const fs::path dir(args.record);
      io::refuse_output_onto_inputs(args.out, "--out", {dir / "mice.csv", dir / "robot.yaml"},
                                    "written by --record too");
    }
  }
  if (const std::string& cal = args.odometry.self_calibration_out; !cal.empty()) {
    io::refuse_output_onto_inputs(cal, "--self-calibration", inputs);
    if (!args.record.empty()) {
      const fs::path dir(args.record);
      io::refuse_output_onto_inputs(cal, "--self-calibration",
                                    {dir / "mice.csv", dir / "robot.yaml"},
                                    "written by --record too");
    }
    if (!args.out.empty() && !to_stdout) {
      io::refuse_output_onto_inputs(cal, "--self-calibration", {args.out}, "the --out of this run");
    }
  }

  LiveSource live = open_source(args.source, config, args.config, hooks);
  io::FrameSource* source = live.source.get();
  const std::string& where = live.where;
  const double t0 = source->start_time();

  // Outputs. The odometry file appears whole at the end; the recording is
  // journalled (see MiceWriter::Durability::kJournal).
  std::unique_ptr<io::MiceWriter> recording;
  if (!args.record.empty()) {
    const fs::path dir(args.record);
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec)
      throw io::Error(fmt::format("{}: cannot create directory ({})", args.record, ec.message()));
    io::write_config(config, dir / "robot.yaml");
    std::vector<std::string> comments{
        fmt::format("recorded by moa live from {}; replay: moa odometry --config {} --log {}",
                    live.origin, (dir / "robot.yaml").string(), dir.string())};
    recording =
        std::make_unique<io::MiceWriter>(dir / "mice.csv", config.names, live.serial != nullptr,
                                         io::MiceWriter::Durability::kJournal, comments);
  }
  std::unique_ptr<io::OdometryCsvWriter> odometry_out;
  if (to_stdout) {
    odometry_out = std::make_unique<io::OdometryCsvWriter>(stdout, config.names, false);
  } else if (!args.out.empty()) {
    odometry_out = std::make_unique<io::OdometryCsvWriter>(args.out, config.names, false);
  }

  std::unique_ptr<io::Dashboard> dashboard;
  if (!args.serve.empty()) {
    io::DashboardOptions options;
    io::parse_listen_address(args.serve, "--serve", options);
    options.title = fmt::format("moa live: {}", live.origin);
    dashboard = std::make_unique<io::Dashboard>(config, options);
    if (!args.quiet) fmt::print(stderr, "moa live: dashboard at {}\n", dashboard->url());
  }

  std::unique_ptr<io::SelfCalibrationCsvWriter> calibration_out;
  if (!args.odometry.self_calibration_out.empty()) {
    calibration_out = std::make_unique<io::SelfCalibrationCsvWriter>(
        args.odometry.self_calibration_out, config.names,
        odometry_options.sensors & all_sensors(config.array.size()));
  }
  const auto odometry = io::make_odometry(config, args.config, t0, odometry_options);
  Pose2 pose = odometry_options.initial.value_or(Pose2{});
  io::RunSummary summary;
  const auto on_step = [&](const OdometryStep& step) {
    pose = step.pose;
    summary.add(step, config.array.size());
    if (odometry_out) odometry_out->write(step);
    if (calibration_out) calibration_out->write(step);
    if (dashboard) dashboard->publish(step);
  };

  RateMeter meter;
  std::size_t rows = 0;
  show_status = [&] {
    if (recording) recording->flush();
    if (to_stdout) odometry_out->flush();
    if (!status) return;
    const auto now = std::chrono::steady_clock::now();
    const std::string alive = live.alive(config);
    fmt::print(
        stderr,
        "\r\033[Kmoa live: {:.1f} s, {:.0f} rows/s, {}, x {:+.3f} m y {:+.3f} m theta {:+.1f} deg",
        std::chrono::duration<double>(now - started).count(), meter.rate(now), alive, pose.t.x(),
        pose.t.y(), to_degrees(pose.theta));
    status_shown = true;
  };

  double t_last = t0;
  const auto feed = [&](const SensorRow& row) {
    if (recording) recording->write(row);
    if (const auto e = odometry->push(row, on_step)) {
      throw io::Error(
          fmt::format("{}: row at t = {} s: {}", where, row.t,
                      e == OdometryError::kRow ? describe(odometry->row_error()) : describe(*e)));
    }
    t_last = row.t;
    ++rows;
    meter.add(1);
  };
  try {
    // The log's clock starts at t0 for every sensor (a no-op row for the
    // synchroniser, whose sensors all start at t0).
    for (int i = 0; i < config.array.size(); ++i) {
      SensorRow start;
      start.t = t0;
      start.sensor = i;
      feed(start);
    }
    while (const auto row = source->next()) feed(*row);
  } catch (...) {
    // What was recorded is good data even if the run failed.
    if (recording) recording->commit();
    if (status_shown) fmt::print(stderr, "\n");
    throw;
  }
  odometry->finish(t_last, on_step);
  if (recording) recording->commit();
  if (odometry_out) odometry_out->commit();
  if (calibration_out) calibration_out->commit();
  if (status_shown) fmt::print(stderr, "\r\033[K");

  if (!args.quiet) {
    std::FILE* report = to_stdout ? stderr : stdout;
    fmt::print(
        report,
        "moa live: {} rows, {} samples over {:.3f} s; final pose x {} m, y {} m, theta {} rad\n",
        rows, odometry->steps(), t_last - t0, pose.t.x(), pose.t.y(), pose.theta);
    summary.fixes = odometry->fixes();
    fmt::print(report, "{}", summary.text());
    if (live.evdev) {
      const auto bindings = parse_bindings(args.source.mice, "--mouse");
      for (std::size_t i = 0; i < bindings.size(); ++i) {
        const auto& d = live.evdev->status(static_cast<int>(i));
        fmt::print(report, "moa live: mouse {}: {} frames, lost {} times, {} SYN_DROPPED\n",
                   bindings[i].name, d.frames, d.lost, d.dropped);
      }
    }
    if (live.serial) {
      const auto& s = live.serial->stats();
      fmt::print(report, "moa live: {} DATA frames, {} lost, {} corrupt\n", s.data_frames,
                 s.lost_frames, s.corrupt);
    }
    if (recording) {
      fmt::print(report, "moa live: recorded to {} (replay: moa odometry --config {} --log {})\n",
                 (fs::path(args.record) / "mice.csv").string(),
                 (fs::path(args.record) / "robot.yaml").string(), args.record);
    }
    if (odometry_out && !to_stdout) {
      fmt::print(report, "moa live: odometry written to {}\n", args.out);
    }
    if (dashboard) {
      const auto d = dashboard->stats();
      fmt::print(report,
                 "moa live: dashboard sent {} events ({} dropped for slow clients, {} clients "
                 "refused)\n",
                 d.events, d.dropped, d.refused);
    }
  }
  return 0;
}

}  // namespace

void add_live(CLI::App& app, Action& action) {
  auto args = std::make_shared<LiveArgs>();
  auto* cmd = app.add_subcommand(
      "live",
      "Live odometry from USB mice (evdev), a serial microcontroller or a replayed log; Ctrl-C "
      "ends");
  cmd->add_option("--config", args->config, "Robot config v1 (YAML)")
      ->required()
      ->check(CLI::ExistingFile);
  add_source_flags(cmd, args->source);
  cmd->add_option("--record", args->record,
                  "Record the rows to DIR (log v1 mice.csv + robot.yaml) for replay with "
                  "`moa odometry`");
  cmd->add_option("--out", args->out, "Write odometry.csv to FILE (at the end), or '-' for stdout");
  // No limit on silences: live rows come at the pace of real time, so a
  // robot parked for hours is no runaway of still epochs.
  args->odometry.options.max_gap = std::numeric_limits<double>::infinity();
  add_odometry_flags(cmd, args->odometry, /*live=*/true);
  cmd->add_option("--serve", args->serve,
                  "[HOST:]PORT: serve the dashboard (a page at /, events at /events) while it "
                  "runs; HOST defaults to 127.0.0.1 (docs/live.md)");
  cmd->add_option("--duration", args->duration, "Stop after this many seconds (0: at Ctrl-C)")
      ->check(kNonNegative);
  cmd->add_flag("--quiet", args->quiet, "No status line and no summary");
  cmd->callback([&action, args] { action = [args] { return run_live(*args); }; });
}

}  // namespace moa::cli
