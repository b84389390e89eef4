// moa live: odometry from devices as they stream, optionally recorded.
//
// Data path: EvdevReader or SerialReader (rows) -> the same Pipeline as
// `moa odometry` -> odometry rows (file or stdout) and a status line.
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
#include "moa/io/config.hpp"
#include "moa/io/error.hpp"
#include "moa/io/evdev.hpp"
#include "moa/io/log.hpp"
#include "moa/io/mice_writer.hpp"
#include "moa/io/odometry_csv.hpp"
#include "moa/io/odometry_run.hpp"
#include "moa/io/serial_reader.hpp"
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
  std::vector<std::string> mice;
  std::string serial;
  int baud = 115200;
  std::string record;
  std::string out;
  OdometryFlags odometry;
  double duration = 0.0;
  double start_timeout = 5.0;
  bool no_grab = false;
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
  if (args.mice.empty() == args.serial.empty()) {
    throw io::Error("give either --mouse NAME=DEV (one per mouse) or --serial DEV");
  }
  const io::RobotConfig config = io::read_config(args.config);
  const OdometryOptions odometry_options =
      resolve_odometry_flags(args.odometry, config, args.config);
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

  std::unique_ptr<io::FrameSource> source;
  io::EvdevReader* evdev = nullptr;
  io::SerialReader* serial = nullptr;
  std::string where;
  if (!args.mice.empty()) {
    std::vector<io::EvdevDevice> devices;
    for (const auto& b : parse_bindings(args.mice, "--mouse")) {
      const auto index = config.index_of(b.name);
      if (!index) {
        throw io::Error(fmt::format("--mouse {}={}: no sensor '{}' in {}", b.name, b.target, b.name,
                                    args.config));
      }
      devices.push_back({b.name, b.target, *index});
    }
    if (static_cast<int>(devices.size()) < config.array.size()) {
      hooks.warning(fmt::format("{} of the {} sensors of {} have a mouse; the others read as still",
                                devices.size(), config.array.size(), args.config));
    }
    io::EvdevOptions options;
    options.grab = !args.no_grab;
    auto reader = std::make_unique<io::EvdevReader>(devices, options, hooks);
    evdev = reader.get();
    source = std::move(reader);
    where = "mice";
  } else {
    io::SerialOptions options;
    options.baud = args.baud;
    options.start_timeout = args.start_timeout;
    auto reader = std::make_unique<io::SerialReader>(args.serial, config, options, hooks);
    serial = reader.get();
    source = std::move(reader);
    where = args.serial;
  }
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
                    evdev ? fmt::format("{} mice (evdev)", args.mice.size()) : args.serial,
                    (dir / "robot.yaml").string(), dir.string())};
    recording = std::make_unique<io::MiceWriter>(dir / "mice.csv", config.names, serial != nullptr,
                                                 io::MiceWriter::Durability::kJournal, comments);
  }
  std::unique_ptr<io::OdometryCsvWriter> odometry_out;
  if (to_stdout) {
    odometry_out = std::make_unique<io::OdometryCsvWriter>(stdout, config.names, false);
  } else if (!args.out.empty()) {
    odometry_out = std::make_unique<io::OdometryCsvWriter>(args.out, config.names, false);
  }

  const auto odometry = io::make_odometry(config, args.config, t0, odometry_options);
  Pose2 pose = odometry_options.initial.value_or(Pose2{});
  const auto on_step = [&](const OdometryStep& step) {
    pose = step.pose;
    if (odometry_out) odometry_out->write(step);
  };

  RateMeter meter;
  std::size_t rows = 0;
  show_status = [&] {
    if (recording) recording->flush();
    if (to_stdout) odometry_out->flush();
    if (!status) return;
    const auto now = std::chrono::steady_clock::now();
    std::string alive;
    if (evdev) {
      alive = fmt::format("mice {}/{} alive", evdev->alive(), args.mice.size());
    } else {
      const bool fresh = serial->seconds_since_data() < 1.0;
      alive = fmt::format("sensors {}/{} alive, {} frames lost",
                          fresh ? serial->hello().names.size() : 0, config.names.size(),
                          serial->stats().lost_frames);
    }
    fmt::print(
        stderr,
        "\r\033[Kmoa live: {:.1f} s, {:.0f} rows/s, {}, x {:+.3f} m y {:+.3f} m theta {:+.1f} deg",
        std::chrono::duration<double>(now - started).count(), meter.rate(now), alive, pose.t.x(),
        pose.t.y(), pose.theta * 180.0 / std::numbers::pi);
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
  if (status_shown) fmt::print(stderr, "\r\033[K");

  if (!args.quiet) {
    std::FILE* report = to_stdout ? stderr : stdout;
    fmt::print(
        report,
        "moa live: {} rows, {} samples over {:.3f} s; final pose x {} m, y {} m, theta {} rad\n",
        rows, odometry->steps(), t_last - t0, pose.t.x(), pose.t.y(), pose.theta);
    if (evdev) {
      const auto bindings = parse_bindings(args.mice, "--mouse");
      for (std::size_t i = 0; i < bindings.size(); ++i) {
        const auto& d = evdev->status(static_cast<int>(i));
        fmt::print(report, "moa live: mouse {}: {} frames, lost {} times, {} SYN_DROPPED\n",
                   bindings[i].name, d.frames, d.lost, d.dropped);
      }
    }
    if (serial) {
      const auto& s = serial->stats();
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
  }
  return 0;
}

}  // namespace

void add_live(CLI::App& app, Action& action) {
  auto args = std::make_shared<LiveArgs>();
  auto* cmd = app.add_subcommand(
      "live", "Live odometry from USB mice (evdev) or a serial microcontroller; Ctrl-C ends");
  cmd->add_option("--config", args->config, "Robot config v1 (YAML)")
      ->required()
      ->check(CLI::ExistingFile);
  auto* mouse = cmd->add_option("--mouse", args->mice,
                                "NAME=DEV: sensor NAME of the config is the evdev device DEV "
                                "(prefer /dev/input/by-path/...-event-mouse); repeat per mouse");
  auto* serial = cmd->add_option("--serial", args->serial,
                                 "Serial port of the acquisition microcontroller "
                                 "(docs/serial-protocol.md)");
  mouse->excludes(serial);
  cmd->add_option("--baud", args->baud, "Baud rate of --serial")
      ->needs(serial)
      ->capture_default_str();
  cmd->add_option("--record", args->record,
                  "Record the rows to DIR (log v1 mice.csv + robot.yaml) for replay with "
                  "`moa odometry`");
  cmd->add_option("--out", args->out, "Write odometry.csv to FILE (at the end), or '-' for stdout");
  // No limit on silences: live rows come at the pace of real time, so a
  // robot parked for hours is no runaway of still epochs.
  args->odometry.options.max_gap = std::numeric_limits<double>::infinity();
  add_odometry_flags(cmd, args->odometry, /*live=*/true);
  cmd->add_option("--duration", args->duration, "Stop after this many seconds (0: at Ctrl-C)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--start-timeout", args->start_timeout,
                  "Seconds to wait for the serial device's HELLO and first DATA")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_flag("--no-grab", args->no_grab,
                "Do not grab the mice (EVIOCGRAB): the desktop cursor follows them too");
  cmd->add_flag("--quiet", args->quiet, "No status line and no summary");
  cmd->callback([&action, args] { action = [args] { return run_live(*args); }; });
}

}  // namespace moa::cli
