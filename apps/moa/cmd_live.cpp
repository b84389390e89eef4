// moa live: odometry from devices as they stream, optionally recorded.
//
// Data path: EvdevReader, SerialReader, OtosReader or ReplayReader (rows;
// runs/live_source.hpp) -> the run loop of `moa odometry` (io::run_loop,
// runs/run_loop.hpp) -> odometry rows (file or stdout), a status line and,
// with --serve, the dashboard (web/dashboard.hpp).
// Recording: every row the pipeline sees goes to DIR/mice.csv, starting with
// a zero row per sensor at the start time so that the log's clock starts
// where the live run's did; `moa odometry --config DIR/robot.yaml --log DIR`
// then reproduces the live odometry exactly (same rows, same t0, times
// written as shortest round-trip text).
//
// Ctrl-C (SIGINT), SIGTERM, SIGHUP (a lost ssh session), SIGPIPE, SIGXFSZ,
// SIGXCPU or SIGQUIT ends the run between rows: the pipeline is flushed and
// every file committed. Rows reach DIR/mice.csv.part at least
// every status tick, so even a killed run leaves its recording there.
#include <fmt/core.h>
#include <fmt/format.h>
#include <signal.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <deque>
#include <exception>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <thread>
#include <type_traits>
#include <variant>
#include <vector>

#include "commands.hpp"
#include "live_source.hpp"
#include "moa/core/wheels.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/diagnostics_csv.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/log.hpp"
#include "moa/formats/mice_writer.hpp"
#include "moa/formats/odometry_csv.hpp"
#include "moa/formats/self_calibration_csv.hpp"
#include "moa/formats/stream_csv.hpp"
#include "moa/runs/odometry_run.hpp"
#include "moa/runs/output_path.hpp"
#include "moa/runs/pose_stream.hpp"
#include "moa/runs/run_loop.hpp"
#include "moa/runs/run_summary.hpp"
#include "moa/sources/stream_lines.hpp"
#include "moa/web/dashboard.hpp"
#include "odometry_options.hpp"

namespace moa::cli {
namespace {

volatile std::sig_atomic_t g_stop = 0;
timespec g_first_stop{};  // when the first stop came (CLOCK_MONOTONIC)

extern "C" void on_stop_signal(int sig) {
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);  // async-signal-safe
  if (!g_stop) {
    g_first_stop = now;
    g_stop = 1;
    return;
  }
  // A second stop within 1 s is the first one delivered twice (a supervisor
  // signals the process and its group); a later one means "now": exit
  // 128 + the signal, the recording's .part file keeping what was flushed.
  const double since = static_cast<double>(now.tv_sec - g_first_stop.tv_sec) +
                       1e-9 * static_cast<double>(now.tv_nsec - g_first_stop.tv_nsec);
  if (since >= 1.0) _exit(128 + sig);
}

// Installs the handlers for the run and puts the old ones back afterwards.
// No SA_RESTART: poll() returns at once with EINTR.
class StopSignals {
 public:
  StopSignals() {
    g_stop = 0;
    struct sigaction action {};
    action.sa_handler = on_stop_signal;
    sigemptyset(&action.sa_mask);  // the handler is not re-entered: all blocked in it
    for (const int signal : kStopSignals) sigaddset(&action.sa_mask, signal);
    for (std::size_t i = 0; i < kStopSignals.size(); ++i) {
      sigaction(kStopSignals[i], nullptr, &old_[i]);
      // One ignored by whoever started moa (nohup's SIGHUP) stays ignored.
      if (old_[i].sa_handler != SIG_IGN) sigaction(kStopSignals[i], &action, nullptr);
    }
  }
  ~StopSignals() {
    for (std::size_t i = 0; i < kStopSignals.size(); ++i) {
      sigaction(kStopSignals[i], &old_[i], nullptr);
    }
  }
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;

 private:
  // Ctrl-C, SIGTERM, and what else ends a run from outside: a lost ssh
  // session (SIGHUP), a reader of standard output gone (SIGPIPE), a file
  // size limit (SIGXFSZ) or a CPU limit (SIGXCPU), SIGQUIT.
  static constexpr std::array<int, 7> kStopSignals{SIGINT,  SIGTERM, SIGHUP, SIGPIPE,
                                                   SIGXFSZ, SIGXCPU, SIGQUIT};
  std::array<struct sigaction, kStopSignals.size()> old_{};
};

struct LiveArgs {
  std::string config;
  SourceFlags source;
  std::string record;
  std::string out;
  std::string serve;
  std::string streams;                   ///< --streams PATH|-|udp:[HOST:]PORT
  std::string streams_clock = "source";  ///< --streams-clock source|monotonic
  std::string pose_out;                  ///< --pose-out -|udp:[HOST:]PORT
  double stream_rate = 0.0;              ///< --stream-rate HZ (0: every step)
  OdometryFlags odometry;
  double duration = 0.0;
  bool quiet = false;
  bool force = false;
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
  // A replay reads a log: its silences are bounded as `moa odometry`
  // bounds them (--max-gap's default unless given), since at --speed the
  // still epochs of its gaps come faster than real time.
  if (!args.source.replay.empty() && std::isinf(args.odometry.options.max_gap)) {
    args.odometry.options.max_gap = OdometryOptions{}.max_gap;
  }
  OdometryOptions odometry_options = resolve_odometry_flags(args.odometry, config, args.config);
  const io::LiveSourceSpec spec = source_spec(args.source, config, args.config);
  // A replayed log's gyro (imu.csv) as `moa odometry` reads it, one sensor
  // without it refused alike, before any output (the streams may bring one).
  io::LogFiles replay_files;
  io::LogStreams replay_log;
  if (!spec.replay.empty()) {
    replay_files = io::resolve_log(spec.replay);
    replay_log =
        io::open_log_streams(config, replay_files, odometry_options, !args.streams.empty());
    // One source per kind: the streams stand for the robot's own program,
    // so its wheels and gyro come from them, not from the log (the rows of
    // two sources of one kind would interleave out of time order).
    if (!args.streams.empty() && (replay_log.wheels || replay_log.imu)) {
      const bool both = replay_log.wheels && replay_log.imu;
      fmt::print(stderr,
                 "moa live: warning: {} of {} not replayed: with --streams the wheels and the "
                 "gyro come from the streams\n",
                 both                ? "wheels.csv and imu.csv"
                 : replay_log.wheels ? "wheels.csv"
                                     : "imu.csv",
                 args.source.replay);
      replay_log.wheels.reset();
      replay_log.imu.reset();
    }
  }
  // As `moa odometry` on the recording: the gyro goes to the consensus and the oracle.
  if (odometry_options.estimator != EstimatorKind::kConsensus &&
      odometry_options.estimator != EstimatorKind::kOracle) {
    odometry_options.use_imu = false;
  }
  for (const auto& w : self_calibration_warnings(odometry_options)) {
    fmt::print(stderr, "moa live: warning: {}\n", w);
  }
  const bool status = !args.quiet && isatty(STDERR_FILENO);
  const bool to_stdout = args.out == "-";
  const bool poses_to_stdout = args.pose_out == "-";
  if (to_stdout && poses_to_stdout) {
    throw io::Error("--out - and --pose-out -: standard output can take one of them");
  }
  const auto started = std::chrono::steady_clock::now();
  StopSignals signals;

  // Shared by the hooks and the loop below.
  bool status_shown = false;
  std::function<void()> show_status;
  io::Dashboard* dashboard_shown = nullptr;  // the dashboard, once it serves
  io::LiveHooks hooks;
  hooks.stop = [&] {
    return g_stop != 0 || (args.duration > 0 && std::chrono::steady_clock::now() - started >=
                                                    std::chrono::duration<double>(args.duration));
  };
  hooks.warn = [&](const std::string& text) {
    if (status_shown) fmt::print(stderr, "\r\033[K");
    fmt::print(stderr, "moa live: warning: {}\n", text);
    if (dashboard_shown != nullptr) dashboard_shown->warn(text);
  };
  hooks.tick = [&] {
    if (show_status) show_status();
  };

  // No output names an input (nor another output).
  std::vector<fs::path> inputs = io::live_source_files(spec);
  inputs.emplace_back(args.config);
  const bool streams_file =
      !args.streams.empty() && args.streams != "-" && args.streams.rfind("udp:", 0) != 0;
  if (streams_file) inputs.emplace_back(args.streams);
  if (!args.record.empty()) {
    const fs::path dir(args.record);
    io::refuse_output_onto_inputs(dir / "mice.csv", "--record", inputs);
    io::refuse_output_onto_inputs(dir / "robot.yaml", "--record", inputs);
    if (!args.streams.empty()) {
      io::refuse_output_onto_inputs(dir / "wheels.csv", "--record", inputs);
      io::refuse_output_onto_inputs(dir / "imu.csv", "--record", inputs);
      io::refuse_output_onto_inputs(dir / "camera.csv", "--record", inputs);
    }
    if (!spec.serial.empty() || !spec.otos.empty() || replay_log.any()) {
      io::refuse_output_onto_inputs(dir / "wheels.csv", "--record", inputs);
      io::refuse_output_onto_inputs(dir / "imu.csv", "--record", inputs);
      io::refuse_output_onto_inputs(dir / "camera.csv", "--record", inputs);
    }
    // A recording is data that cannot be made again: replaced only when asked.
    for (const char* name :
         {"mice.csv", "mice.csv.part", "robot.yaml", "wheels.csv", "imu.csv", "camera.csv"}) {
      std::error_code ec;
      if (!args.force && fs::exists(dir / name, ec)) {
        throw io::Error(
            fmt::format("--record {}: holds a recording ({}); pass --force to replace "
                        "it",
                        args.record, name));
      }
    }
    // Replaced as a whole: the streams an earlier recording left beside its
    // mice would otherwise be replayed with the new ones (unless one of them
    // is an input: refused).
    for (const char* name : {"wheels.csv", "imu.csv", "camera.csv"}) {
      io::refuse_output_onto_inputs(dir / name, "--record", inputs);
      std::error_code ec;
      fs::remove(dir / name, ec);
    }
  }
  // What --record writes (or removes: the streams are replaced as a whole).
  std::vector<fs::path> recorded;
  if (!args.record.empty()) {
    const fs::path dir(args.record);
    for (const char* name : {"mice.csv", "robot.yaml", "wheels.csv", "imu.csv", "camera.csv"}) {
      recorded.push_back(dir / name);
    }
  }
  if (!args.out.empty() && !to_stdout) {
    io::refuse_output_onto_inputs(args.out, "--out", inputs);
    io::refuse_output_onto_inputs(args.out, "--out", recorded, "written by --record too");
  }
  if (const std::string& cal = args.odometry.self_calibration_out; !cal.empty()) {
    io::refuse_output_onto_inputs(cal, "--self-calibration", inputs);
    io::refuse_output_onto_inputs(cal, "--self-calibration", recorded, "written by --record too");
    if (!args.out.empty() && !to_stdout) {
      io::refuse_output_onto_inputs(cal, "--self-calibration", {args.out}, "the --out of this run");
    }
  }
  if (const std::string& diag = args.odometry.diagnostics_out; !diag.empty()) {
    io::refuse_output_onto_inputs(diag, "--diagnostics", inputs);
    io::refuse_output_onto_inputs(diag, "--diagnostics", recorded, "written by --record too");
    io::refuse_output_onto_inputs(
        diag, "--diagnostics",
        {to_stdout ? fs::path{} : fs::path(args.out), args.odometry.self_calibration_out},
        "another output of this run");
  }

  // The pose stream, before any file is written: a bad target leaves none.
  // It never waits for its reader (runs/pose_stream.hpp).
  std::unique_ptr<io::PoseStream> pose_stream;
  if (!args.pose_out.empty()) {
    pose_stream = std::make_unique<io::PoseStream>(args.pose_out, config.names, args.stream_rate);
  }

  io::LiveSource live = io::open_live_source(spec, config, args.config, hooks);
  // Waits for the source to start (a serial board's HELLO): no output exists before.
  io::LiveRunSource input(*live.source, config.array.size(), live.where);
  const double source_speed = spec.replay.empty() ? 1.0 : spec.replay_options.speed;
  std::unique_ptr<io::StreamLineReader> streams;
  if (!args.streams.empty()) {
    // The source's clock from the first line on: a line far ahead of it is
    // refused, never taken as its stream's time.
    streams = std::make_unique<io::StreamLineReader>(
        args.streams,
        args.streams_clock == "monotonic" ? io::StreamClock::kMonotonic : io::StreamClock::kSource,
        io::SourceClock{input.start_time(), std::chrono::steady_clock::now(), source_speed});
  }

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
    recording = std::make_unique<io::MiceWriter>(
        dir / "mice.csv", config.names,
        live.serial != nullptr || live.otos != nullptr || live.replay != nullptr,
        io::MiceWriter::Durability::kJournal, comments);
  }
  // The streams' rows, a serial board's gyro, the replayed log's wheels.csv,
  // camera.csv and imu.csv.
  std::unique_ptr<io::StreamCsvWriter> stream_recording;
  if (recording && (!args.streams.empty() || live.gyro != nullptr || replay_log.any())) {
    stream_recording = std::make_unique<io::StreamCsvWriter>(
        args.record, !args.streams.empty()
                         ? fmt::format("recorded by moa live from the streams of {}", args.streams)
                     : live.gyro != nullptr
                         ? fmt::format("recorded by moa live from the gyro of {} (t: s; gz: rad/s, "
                                       "counter-clockwise about z)",
                                       live.where)
                         : fmt::format("recorded by moa live from a replay of {}", live.where));
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
    dashboard_shown = dashboard.get();
    for (const auto& w : self_calibration_warnings(odometry_options)) dashboard->warn(w);
  }

  std::unique_ptr<io::DiagnosticsCsvWriter> diagnostics_out;
  if (!args.odometry.diagnostics_out.empty()) {
    diagnostics_out = std::make_unique<io::DiagnosticsCsvWriter>(
        args.odometry.diagnostics_out, config.names,
        odometry_options.sensors & all_sensors(config.array.size()));
  }
  std::unique_ptr<io::SelfCalibrationCsvWriter> calibration_out;
  if (!args.odometry.self_calibration_out.empty()) {
    calibration_out = std::make_unique<io::SelfCalibrationCsvWriter>(
        args.odometry.self_calibration_out, config.names,
        odometry_options.sensors & all_sensors(config.array.size()));
  }
  Pose2 pose = odometry_options.initial.value_or(Pose2{});
  io::RunCallbacks callbacks;
  callbacks.on_step = [&](const OdometryStep& step) {
    pose = step.pose;
    if (pose_stream) pose_stream->write(step);
    if (odometry_out) odometry_out->write(step);
    if (calibration_out) calibration_out->write(step);
    if (diagnostics_out) diagnostics_out->write(step);
    if (dashboard) dashboard->publish(step);
  };

  // A recording that cannot be written (a full disk) stops there, said once;
  // the run goes on and its other outputs (--out on another disk) are
  // written; the error is the run's at the end. What was flushed stays in
  // DIR/mice.csv.part.
  std::exception_ptr recording_error;
  const auto record = [&](auto&& write) {
    if (recording_error) return;
    try {
      write();
    } catch (const io::Error& e) {
      recording_error = std::current_exception();
      hooks.warning(fmt::format(
          "--record {}: {}: the recording stops here (what was flushed stays in {}); the run goes "
          "on and writes its other outputs",
          args.record, e.what(), recording ? recording->partial_path().string() : args.record));
    }
  };
  RateMeter meter;
  callbacks.on_row = [&](const io::InputRow& row) {
    if (const auto* mice = std::get_if<SensorRow>(&row)) {
      if (recording) record([&] { recording->write(*mice); });
      meter.add(1);
    } else if (stream_recording) {
      std::visit(
          [&](const auto& r) {
            if constexpr (!std::is_same_v<std::decay_t<decltype(r)>, SensorRow>) {
              record([&] { stream_recording->write(r); });
            }
          },
          row);
    }
  };
  // The robot's streams: bad lines said once per kind, as they come; rows
  // beyond a bound (a burst, a flood) dropped and counted, said once.
  // Rows the pipeline could not hold: wheel rows, gyro rows, fixes.
  std::array<std::size_t, 3> stream_full{};
  bool overflow_said = false;
  bool not_lines_said = false;
  const auto say_bad_lines = [&] {
    if (!streams) return;
    while (const auto bad = streams->take_new_error()) {
      hooks.warning(fmt::format("--streams: {}: '{}' (more such lines are counted, not shown)",
                                describe(bad->first), bad->second));
    }
    const auto stats = streams->stats();
    if (stats.not_lines && !not_lines_said) {
      not_lines_said = true;
      hooks.warning(fmt::format(
          "--streams {}: {} bytes without a line end: not a stream of lines; no more of it is "
          "read",
          args.streams, io::kMaxStreamUnended));
    }
    if (overflow_said) return;
    if (const std::size_t queued = stats.overflow; queued != 0) {
      overflow_said = true;
      hooks.warning(fmt::format(
          "--streams: lines dropped: {} good lines were waiting to be fed (lines coming faster "
          "than the run takes them); further such lines are dropped and counted",
          io::kMaxQueuedLines));
    } else if (input.overflow() != 0) {
      overflow_said = true;
      hooks.warning(fmt::format(
          "--streams: rows dropped: {} rows of a stream were waiting for the mice rows of their "
          "times; further such rows are dropped and counted",
          io::LiveRunSource::kMaxHeldRows));
    }
  };
  callbacks.on_stream_full = [&](const io::InputRow& row, const std::string&) {
    const std::size_t kind_index = std::holds_alternative<io::WheelRow>(row) ? 0
                                   : std::holds_alternative<io::ImuRow>(row) ? 1
                                                                             : 2;
    if (stream_full[kind_index]++ != 0 || overflow_said) return;
    overflow_said = true;
    const char* kind = std::holds_alternative<io::WheelRow>(row) ? "wheel rows"
                       : std::holds_alternative<io::ImuRow>(row) ? "gyro rows"
                                                                 : "camera fixes";
    hooks.warning(fmt::format(
        "{}: {} dropped from t = {:.6f} s: a burst came faster than the mice rows take them (at "
        "most "
        "{} wait ahead of the mice rows); further such rows are dropped and counted, the run "
        "goes on",
        input.where(), kind, io::row_time(row),
        std::holds_alternative<CameraFix>(row) ? Odometry::kMaxPendingFixes
                                               : IntervalAverager<3>::kCapacity));
  };
  callbacks.warn = hooks.warn;
  show_status = [&] {
    say_bad_lines();
    if (recording) record([&] { recording->flush(); });
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

  if (streams) input.add_streams(*streams, source_speed);
  if (live.gyro != nullptr) input.add_gyro(*live.gyro);
  if (replay_log.any()) input.add_log(replay_log, replay_files);
  // A live input's bad row (a saturated record, a time out of order) is
  // skipped and not recorded, so that the recording replays; each kind is
  // reported once, with the count at the end.
  std::map<std::string, std::size_t> skipped;
  callbacks.on_refused = [&](const SensorRow& row, const std::string& why) {
    if (skipped[why]++ != 0) return;
    const bool known = row.sensor >= 0 && row.sensor < config.array.size();
    hooks.warn(fmt::format(
        "{}: row at t = {} s of sensor {} skipped: {} (further such rows are skipped and "
        "counted)",
        live.where, row.t,
        known ? fmt::format("'{}'", config.names[static_cast<std::size_t>(row.sensor)]) : "?",
        why));
  };
  io::OdometryRun run;
  try {
    run = io::run_loop(config, args.config, odometry_options, input, live.where, callbacks);
  } catch (...) {
    // What was recorded is good data even if the run failed.
    if (recording) record([&] { recording->commit(); });
    if (stream_recording) record([&] { stream_recording->commit(); });
    if (status_shown) fmt::print(stderr, "\n");
    if (recording) {
      fmt::print(stderr, "moa live: the recording up to the error is kept in {}\n", args.record);
    }
    throw;
  }
  if (streams) {
    streams->stop();
    say_bad_lines();
  }
  for (const auto& [why, count] : skipped) {
    hooks.warn(fmt::format("{}: {} rows skipped: {}", live.where, count, why));
  }
  if (recording) record([&] { recording->commit(); });
  if (stream_recording) record([&] { stream_recording->commit(); });
  if (odometry_out) odometry_out->commit();
  if (pose_stream) {
    // The lines still buffered for a slow reader get a moment, then are dropped.
    pose_stream->finish(std::chrono::milliseconds(500));
    run.summary.pose_lines = pose_stream->stats().lines;
    run.summary.pose_lines_dropped = pose_stream->stats().dropped;
    // Standard output blocking again before the summary: on a terminal,
    // standard error shares its flags.
    pose_stream.reset();
  }
  if (calibration_out) calibration_out->commit();
  if (diagnostics_out) diagnostics_out->commit();
  if (status_shown) fmt::print(stderr, "\r\033[K");

  if (!args.quiet) {
    std::FILE* report = to_stdout || poses_to_stdout ? stderr : stdout;
    fmt::print(
        report,
        "moa live: {} rows, {} samples over {:.3f} s; final pose x {:.4f} m, y {:.4f} m, theta "
        "{:.2f} deg\n",
        run.rows, run.steps, run.t_end - run.t0, pose.t.x(), pose.t.y(),
        to_degrees(wrap_angle(pose.theta)));
    fmt::print(report, "{}", run.summary.text());
    if (live.evdev) {
      for (std::size_t i = 0; i < spec.mice.size(); ++i) {
        const auto& d = live.evdev->status(static_cast<int>(i));
        fmt::print(report, "moa live: mouse {}: {} frames, lost {} times, {} SYN_DROPPED\n",
                   spec.mice[i].name, d.frames, d.lost, d.dropped);
      }
    }
    if (live.otos) {
      for (int i = 0; i < live.otos->units(); ++i) {
        const auto& u = live.otos->stats(i);
        fmt::print(report,
                   "moa live: OTOS {}: {} rows from {} reads; {} failed reads, silent {} times ({} "
                   "lift rows); tracking lost {}, optical fault {}, tilt {}, IMU fault {}; "
                   "dropped {} corrupt, {} impossible\n",
                   live.otos->where(i), u.rows, u.polls, u.read_errors, u.silences, u.silent_rows,
                   u.tracking_lost, u.optical_fault, u.tilt, u.imu_fault, u.corrupt, u.implausible);
      }
    }
    if (live.serial) {
      const auto& s = live.serial->stats();
      fmt::print(report, "moa live: {} DATA frames, {} lost, {} corrupt; {} gyro samples\n",
                 s.data_frames, s.lost_frames, s.corrupt, s.gyro_frames);
    }
    if (streams) {
      const auto st = streams->stats();
      // Handed out by the merge, less what the pipeline could not hold.
      const auto fed = [](std::size_t out, std::size_t full) { return out - std::min(out, full); };
      fmt::print(report,
                 "moa live: streams: {} wheel rows, {} gyro rows and {} camera fixes read, {}, {} "
                 "and {} fed; {} bad lines, {} out of time order, {} dropped past a bound\n",
                 st.wheels, st.imu, st.fixes, fed(input.streamed().wheels, stream_full[0]),
                 fed(input.streamed().imu, stream_full[1]),
                 fed(input.streamed().fixes, stream_full[2]), st.bad_total(), input.dropped(),
                 st.overflow + input.overflow() + stream_full[0] + stream_full[1] + stream_full[2]);
    }
    if (recording && !recording_error) {
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
  if (dashboard) {
    dashboard->finish();
    // Someone at a terminal (a short replay ends before a page is opened):
    // the dashboard keeps serving the run's final state until Ctrl-C.
    if (g_stop == 0 && isatty(STDIN_FILENO) && isatty(STDERR_FILENO)) {
      fmt::print(stderr,
                 "moa live: the run ended; the dashboard at {} shows its final state until "
                 "Ctrl-C\n",
                 dashboard->url());
      while (g_stop == 0) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }
  // The recording's error, once everything else is written.
  if (recording_error) std::rethrow_exception(recording_error);
  return 0;
}

}  // namespace

void add_live(CLI::App& app, Action& action) {
  auto args = std::make_shared<LiveArgs>();
  auto* cmd = app.add_subcommand(
      "live",
      "Live odometry from USB mice (evdev), a serial microcontroller, SparkFun OTOS units (I2C) "
      "or a replayed log; Ctrl-C "
      "ends");
  cmd->add_option("--config", args->config, "Robot config v1 (YAML)")
      ->required()
      ->check(CLI::ExistingFile);
  add_source_flags(cmd, args->source);
  cmd->add_option("--record", args->record,
                  "Record the rows fed to DIR (log v1 mice.csv + robot.yaml; a serial board's or "
                  "a replayed log's gyro to imu.csv, t,gz in s, rad/s; a replayed log's and the "
                  "streams' wheels to wheels.csv, the streams' fixes to camera.csv) for replay "
                  "with `moa odometry`")
      ->check(output_file_name());
  cmd->add_option("--out", args->out, "Write odometry.csv to FILE (at the end), or '-' for stdout")
      ->check(output_file_or_stdout());
  // No limit on silences: live rows come at the pace of real time, so a
  // robot parked for hours is no runaway of still epochs (a replay: see
  // run_live).
  args->odometry.options.max_gap = std::numeric_limits<double>::infinity();
  add_odometry_flags(cmd, args->odometry, /*live=*/true);
  cmd->add_option("--serve", args->serve,
                  "[HOST:]PORT: serve the dashboard (a page at /, events at /events) while it "
                  "runs; HOST defaults to 127.0.0.1 (docs/live.md)");
  cmd->add_option("--streams", args->streams,
                  "PATH|-|udp:[HOST:]PORT: the robot's wheel twists, gyro rates and camera "
                  "fixes, one CSV or JSON line each (wheels,t,vx,vy,omega or imu,t,gz or "
                  "camera,t,x,y[,theta[,sx,sy]]; t empty: stamped at arrival), from a FIFO, a "
                  "file, standard input or a UDP port (HOST defaults to 127.0.0.1; "
                  "docs/formats/stream-lines.md); recorded by --record")
      ->type_name("PATH|-|udp:[HOST:]PORT");
  cmd->add_option("--streams-clock", args->streams_clock,
                  "The clock of a --streams line's t: 'source' (the live source's: a replayed "
                  "log's, the board's) or 'monotonic' (this machine's CLOCK_MONOTONIC, s, as "
                  "Python's time.monotonic(); mapped onto the source's clock at arrival)")
      ->check(CLI::IsMember({"source", "monotonic"}))
      ->capture_default_str();
  cmd->add_option("--pose-out", args->pose_out,
                  "-|udp:[HOST:]PORT: a JSON line per step (t, pose in 'odom', twist in "
                  "'base_link', 6x6 covariances, source, used and excluded sensors; "
                  "docs/formats/pose-stream.md) to standard output or UDP (HOST defaults to "
                  "127.0.0.1), never waiting for the reader: lines it cannot take are dropped "
                  "and counted in the summary")
      ->type_name("-|udp:[HOST:]PORT");
  cmd->add_option("--stream-rate", args->stream_rate,
                  "HZ: --pose-out lines per second of the steps' time (0: every step)")
      ->check(finite_within(0.0, 1e6))
      ->capture_default_str();
  cmd->add_option("--duration", args->duration, "Stop after this many seconds (0: at Ctrl-C)")
      ->check(kNonNegative);
  cmd->add_flag("--quiet", args->quiet, "No status line and no summary");
  cmd->add_flag("--force", args->force, "Replace the recording in --record DIR if there is one");
  cmd->callback([&action, args] { action = [args] { return run_live(*args); }; });
}

}  // namespace moa::cli
