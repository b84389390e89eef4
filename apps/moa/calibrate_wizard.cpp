// moa calibrate --guided --live: walks the user through the guided
// calibration (docs/calibration.md) with live data. The session
// (moa::GuidedSession, calibration/guided_session.hpp) decides which motion
// is asked for, watches it in the nominal config's odometry (the run loop of
// `moa live`, runs/run_loop.hpp) and keeps or redoes it; this file says what
// to do, prints how each motion went, maps keys to keep and redo, then runs
// calibrate_guided on the kept motions' count totals, writes the config and
// prints the mounts before and after with their 1-sigma.
//
// Keys (the terminal is put in non-canonical mode while it runs, so no
// Enter is needed after a letter): Enter or y keeps a motion, r redoes it,
// k keeps a motion that failed a check, q quits without writing anything.
// A replay waits while the wizard waits for a key (LiveHooks::hold), so a
// late key skips nothing, and a motion watched at the end of the data still
// takes its key. From a device, data that arrives while the wizard waits is
// not watched: after the key, the robot must be still again before the next
// motion counts.
#include "calibrate_wizard.hpp"

#include <fmt/core.h>
#include <fmt/format.h>
#include <poll.h>
#include <signal.h>
#include <termios.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <numbers>
#include <vector>

#include "moa/calibration/calibrate.hpp"
#include "moa/calibration/guided_session.hpp"
#include "moa/calibration/guided_steps.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/error.hpp"
#include "moa/runs/calibration_run.hpp"
#include "moa/runs/odometry_run.hpp"
#include "moa/runs/output_path.hpp"
#include "moa/runs/run_loop.hpp"

namespace moa::cli {
namespace {

volatile std::sig_atomic_t g_quit = 0;
extern "C" void on_quit_signal(int) { g_quit = 1; }

// The spin's rows are kept in memory for the gyro's calibration: at most
// this many of each kind (mice, gyro), about 9 min of four sensors at 1 kHz.
constexpr std::size_t kMaxSpinRows = std::size_t{1} << 21;

// Non-canonical, no echo, for single keys; restored (and the signal
// handlers put back) on every way out.
class Terminal {
 public:
  Terminal() {
    struct sigaction action {};
    action.sa_handler = on_quit_signal;
    sigemptyset(&action.sa_mask);
    sigaction(SIGINT, &action, &old_int_);
    sigaction(SIGTERM, &action, &old_term_);
    sigaction(SIGHUP, &action, &old_hup_);  // a lost ssh session: nothing written, as q
    g_quit = 0;
    if (isatty(STDIN_FILENO) && tcgetattr(STDIN_FILENO, &saved_) == 0) {
      termios raw = saved_;
      raw.c_lflag &= ~static_cast<tcflag_t>(ICANON | ECHO);
      raw.c_cc[VMIN] = 0;
      raw.c_cc[VTIME] = 0;
      restore_ = tcsetattr(STDIN_FILENO, TCSANOW, &raw) == 0;
    }
  }
  ~Terminal() {
    if (restore_) tcsetattr(STDIN_FILENO, TCSANOW, &saved_);
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
    sigaction(SIGHUP, &old_hup_, nullptr);
  }
  Terminal(const Terminal&) = delete;
  Terminal& operator=(const Terminal&) = delete;

  /// Standard input ended: no key will come.
  bool closed() const { return eof_; }
  /// A key if one was pressed, without waiting.
  std::optional<char> key() {
    if (eof_) return std::nullopt;
    pollfd p{STDIN_FILENO, POLLIN, 0};
    if (poll(&p, 1, 0) <= 0) return std::nullopt;
    char c = 0;
    const ssize_t n = read(STDIN_FILENO, &c, 1);
    if (n == 0) eof_ = true;
    if (n != 1) return std::nullopt;
    return c;
  }

 private:
  termios saved_{};
  bool restore_ = false;
  bool eof_ = false;
  struct sigaction old_int_ {};
  struct sigaction old_term_ {};
  struct sigaction old_hup_ {};
};

template <class... Args>
void say(fmt::format_string<Args...> format, Args&&... args) {
  fmt::print(format, std::forward<Args>(args)...);
  std::fflush(stdout);
}

void print_mounts(const io::RobotConfig& config, const GuidedCalibration& cal) {
  const std::array<const char*, kMountParameters> labels{"x mm", "y mm", "yaw deg", "scale x",
                                                         "scale y"};
  const std::array<double, kMountParameters> unit{1e3, 1e3, to_degrees(1.0), 1.0, 1.0};
  const std::array<int, kMountParameters> digits{3, 3, 3, 5, 5};
  for (std::size_t i = 0; i < cal.sensors.size(); ++i) {
    const SensorCalibration& c = cal.sensors[i];
    const MountVector before = mount_parameters(c.nominal);
    const MountVector after = mount_parameters(c.calibrated);
    const MountVector sd = c.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
    say("\nsensor {:<10} {:>12} {:>12} {:>12}\n", config.names[i], "before", "after", "1-sigma");
    for (int p = 0; p < kMountParameters; ++p) {
      const auto k = static_cast<std::size_t>(p);
      say("  {:<15} {:>12.{}f} {:>12.{}f} {:>12.{}f}\n", labels[k], before(p) * unit[k], digits[k],
          after(p) * unit[k], digits[k], sd(p) * unit[k], digits[k]);
    }
    say("  {:<15} {:>12} {:>12}\n", "mirrored", c.nominal.mirrored ? "yes" : "no",
        c.calibrated.mirrored ? "yes" : "no");
  }
}

}  // namespace

void add_wizard_flags(CLI::App* cmd, WizardArgs& w) {
  cmd->add_flag("--guided", w.guided,
                "The guided calibration: with --live, a step-by-step session with live data "
                "(docs/live.md); without, the same as --method guided");
  cmd->add_flag("--live", w.live,
                "With --guided: watch the motions live from --mouse, --serial, --otos or --replay");
  add_source_flags(cmd, w.source);
  cmd->add_flag("--no-push-y", w.no_push_y,
                "With --guided --live: skip the push along y (scales taken equal on both axes)");
}

void refuse_live_flags(const WizardArgs& args) {
  const SourceFlags& f = args.source;
  if (!f.mice.empty() || !f.serial.empty() || !f.otos.empty() || !f.replay.empty() ||
      args.no_push_y) {
    throw io::Error(
        "--mouse, --serial, --otos, --replay and --no-push-y belong to --guided --live (the live "
        "guided calibration)");
  }
}

int run_wizard(const WizardArgs& args) {
  if (!args.guided) throw io::Error("--live needs --guided (the live guided calibration)");
  if (args.imu && args.imu_reference != "array") {
    throw io::Error(fmt::format(
        "--imu-reference {}: the live guided calibration calibrates the gyro against the array "
        "only (record the spin with `moa live --record DIR` and run --method guided on it, or "
        "give --no-imu)",
        args.imu_reference));
  }
  const io::RobotConfig config = io::read_config(args.config);
  MotionLimits limits;
  limits.distance = args.distance.value_or(1.0);
  limits.turns = args.turns.value_or(3.0);
  if (!(std::isfinite(limits.distance) && limits.distance > 0.0)) {
    throw io::Error(
        fmt::format("--distance {}: must be a positive number of metres", limits.distance));
  }
  if (!std::isfinite(limits.turns) || limits.turns == 0.0) {
    throw io::Error(fmt::format("--turns {}: must be a non-zero number of turns", limits.turns));
  }
  const io::LiveSourceSpec spec = source_spec(args.source, config, args.config);
  std::vector<std::filesystem::path> inputs = io::live_source_files(spec);
  inputs.emplace_back(args.config);
  io::refuse_output_onto_inputs(args.out, "--out", inputs);

  Terminal terminal;
  io::LiveHooks hooks;
  std::function<void()> poll_keys;
  std::function<bool()> waiting_for_key;
  hooks.stop = [] { return g_quit != 0; };
  hooks.tick = [&] {
    if (poll_keys) poll_keys();
  };
  hooks.hold = [&] { return waiting_for_key && waiting_for_key(); };
  hooks.warn = [](const std::string& text) { say("warning: {}\n", text); };
  io::LiveSource live = io::open_live_source(spec, config, args.config, hooks);
  live.source->start_time();  // waits for the source to start (a serial board's HELLO)

  // The gyro beside the array: a serial board's, or a replayed log's imu.csv.
  io::LogFiles replay_files;
  io::LogStreams replay_log;
  if (args.imu && !spec.replay.empty()) {
    replay_files = io::resolve_log(spec.replay);
    if (replay_files.imu) replay_log.imu = std::make_unique<io::ImuReader>(*replay_files.imu);
  }
  const bool gyro_possible = args.imu && (live.gyro != nullptr || replay_log.imu);
  say("moa calibrate --guided --live: {} sensors of {}, from {}{}\n", config.names.size(),
      args.config, live.origin,
      gyro_possible ? "; the spin calibrates the gyro too, if one sends its rows (--no-imu: the "
                      "mice alone)"
                    : "");
  say("Keys: Enter keeps a motion, r redoes it, k keeps one that failed a check, q quits.\n");

  GuidedSession session(config.array, limits, !args.no_push_y);
  bool quit = false;
  // The spin's rows, from the moment it is asked for (the robot still)
  // until it is watched, for the gyro's calibration (as --method guided
  // reads them from the spin's mice.csv and imu.csv).
  io::SpinRecording spin;
  spin.mice_where = fmt::format("the spin's rows from {}", live.where);
  spin.imu_where = fmt::format("the spin's gyro rows from {}",
                               replay_log.imu ? replay_files.imu->string() : live.where);
  bool recording = false, spin_overflow = false, gyro_seen = false;
  double last_row_t = 0.0;
  const auto announce_step = [&] {
    const GuidedStep step = session.steps()[session.current()];
    recording = gyro_possible && step == GuidedStep::kSpin;
    if (recording) {
      spin.start = last_row_t;
      spin.mice.clear();
      spin.imu.clear();
      spin_overflow = false;
    }
    say("\nStep {} of {}: {}\n  {}\n  Hold the robot still...\n", session.current() + 1,
        session.steps().size(), describe(step), instructions(step, limits));
  };
  const auto on_key = [&](char key) {
    if (key == 'q' || key == 'Q') {
      quit = true;
      return;
    }
    const MotionSummary* pending = session.pending();
    if (pending == nullptr) return;
    const bool keep = key == '\n' || key == '\r' || key == 'y' || key == 'Y';
    const bool redo = key == 'r' || key == 'R' || (!pending->good() && keep);
    const bool force = key == 'k' || key == 'K';
    if (redo) {
      session.redo();
      say("  Again.\n");
      announce_step();
    } else if ((keep || force) && session.keep(force)) {
      say("  Kept.\n");
      recording = false;
      if (!session.complete()) announce_step();
    }
  };
  poll_keys = [&] {
    while (const auto key = terminal.key()) on_key(*key);
  };
  waiting_for_key = [&] { return session.pending() != nullptr && !quit && !terminal.closed(); };
  io::RunCallbacks callbacks;
  callbacks.on_step = [&](const OdometryStep& step) {
    if (quit || g_quit != 0) return;  // the last epochs, after the user quit
    switch (session.feed(step)) {
      case GuidedSession::Event::kNone:
        return;
      case GuidedSession::Event::kReady:
        say("  Ready: go.\n");
        return;
      case GuidedSession::Event::kMoving:
        say("  Moving...\n");
        return;
      case GuidedSession::Event::kWatched:
        break;
    }
    const MotionSummary& summary = *session.pending();
    say("  Watched: {}\n", summarise(summary));
    if (summary.good()) {
      say("  Good enough. Enter: keep it, r: redo\n");
      return;
    }
    say("  Not good enough:\n");
    for (const auto problem : summary.problems) {
      say("    - {}\n", explain(summary, problem, limits));
    }
    if (summary.lifted_sensor >= 0) {
      say("    (sensor {})\n", config.names[static_cast<std::size_t>(summary.lifted_sensor)]);
    }
    say("  r or Enter: redo, k: keep it anyway\n");
  };
  const auto record = [&](auto& rows, const auto& row) {
    if (rows.size() < kMaxSpinRows) {
      rows.push_back(row);
    } else if (!spin_overflow) {
      spin_overflow = true;
      say("warning: the spin has gone on for over {} rows: the gyro will not be calibrated from "
          "it (r redoes it)\n",
          kMaxSpinRows);
    }
  };
  callbacks.on_row = [&](const io::InputRow& row) {
    const bool watching = recording && session.pending() == nullptr;
    if (const auto* r = std::get_if<SensorRow>(&row)) {
      if (watching && r->t > spin.start) record(spin.mice, *r);
      last_row_t = std::max(last_row_t, r->t);
    } else if (const auto* g = std::get_if<io::ImuRow>(&row)) {
      gyro_seen = true;
      if (watching) record(spin.imu, *g);
    }
    poll_keys();
  };
  callbacks.warn = hooks.warn;

  session.begin_step();
  announce_step();
  io::LiveRunSource input(*live.source, config.array.size(), live.where,
                          [&] { return quit || session.complete() || g_quit != 0; });
  if (live.gyro != nullptr && args.imu) input.add_gyro(*live.gyro);
  if (replay_log.imu) input.add_log(replay_log, replay_files);
  io::run_loop(config, args.config, guided_session_odometry_options(), input, live.where,
               callbacks);
  // The data ended with a motion watched (its end is seen in the last
  // epochs): its key still counts.
  while (waiting_for_key() && g_quit == 0) {
    poll_keys();
    poll(nullptr, 0, 50);
  }
  if (quit || g_quit != 0) {
    say("\nCalibration abandoned: nothing written.\n");
    return 1;
  }
  if (!session.complete()) {
    say("\nThe data ended before the calibration was complete: nothing written.\n");
    return 1;
  }

  const auto result = calibrate_guided(config.array, session.input(), args.tolerances);
  if (const auto* e = std::get_if<CalibrationError>(&result)) {
    throw io::Error(fmt::format("the guided calibration failed: {}", describe(*e)));
  }
  const auto& cal = std::get<GuidedCalibration>(result);
  io::RobotConfig out = config;
  out.array = cal.calibrated;
  // The gyro against the array at the mounts just calibrated, as --method
  // guided does with the spin's imu.csv; refused (nothing written) as there.
  std::optional<io::CalibrationSummary> gyro;
  if (gyro_possible && !spin_overflow && !spin.imu.empty()) {
    io::CalibrationSummary r;
    r.method = io::CalibrationMethod::kGuided;
    r.calibrated = out;
    io::calibrate_spin_gyro(r, config, spin);
    out.imu = r.calibrated.imu;
    gyro = std::move(r);
  }
  io::write_config(out, args.out);

  say("\nCalibrated from the kept motions ({} m pushes, {} turns); positions relative to the "
      "point the robot was spun about. Before -> after +- 1-sigma:\n",
      limits.distance, std::abs(limits.turns));
  print_mounts(config, cal);
  for (const auto& w : guided_result_warnings(cal, limits.distance, config.names)) {
    say("warning: {}\n", w);
  }
  if (gyro) {
    say("\n{}", gyro->gyro->table());
    for (const auto& f : gyro->facts) say("{}\n", f);
    for (const auto& w : gyro->warnings) say("warning: {}\n", w);
  } else if (gyro_possible && gyro_seen) {  // a serial board may have no gyro
    say("\nwarning: the gyro was not calibrated ({}): the config keeps the imu: block of {}\n",
        spin_overflow ? "the spin was too long to keep" : "no gyro rows came during the spin",
        args.config);
  }
  say("calibrated config written to {}\n", args.out);
  return 0;
}

}  // namespace moa::cli
