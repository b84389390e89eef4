// moa calibrate --guided --live: walks the user through the guided
// calibration (docs/calibration.md) with live data. For each motion it says
// what to do, watches it in the nominal config's odometry
// (moa::MotionWatcher, calibration/guided_steps.hpp), says whether it is
// good enough or why not, and lets the user keep it or redo it with a key;
// then it runs calibrate_guided on the three motions' count totals, writes
// the config and prints the mounts before and after with their 1-sigma.
//
// Keys (the terminal is put in non-canonical mode while it runs, so no
// Enter is needed after a letter): Enter or y keeps a motion, r redoes it,
// k keeps a motion that failed a check, q quits without writing anything.
// Data that arrives while the wizard waits for a key is not watched: after
// the key, the robot must be still again before the next motion counts.
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
#include "moa/calibration/guided_steps.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/error.hpp"
#include "moa/runs/odometry_run.hpp"
#include "moa/runs/output_path.hpp"

namespace moa::cli {
namespace {

volatile std::sig_atomic_t g_quit = 0;
extern "C" void on_quit_signal(int) { g_quit = 1; }

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
  }
  Terminal(const Terminal&) = delete;
  Terminal& operator=(const Terminal&) = delete;

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
};

template <class... Args>
void say(fmt::format_string<Args...> format, Args&&... args) {
  fmt::print(format, std::forward<Args>(args)...);
  std::fflush(stdout);
}

std::string instructions(GuidedStep step, const MotionLimits& l) {
  switch (step) {
    case GuidedStep::kPushX:
      return fmt::format(
          "Put the robot's side against a straight edge and mark where it starts. Push it {} m "
          "forward (+x) along the edge, without turning it, then hold it still.",
          l.distance);
    case GuidedStep::kPushY:
      return fmt::format(
          "Put the robot's front against the straight edge and mark where it starts. Push it {} m "
          "to its left (+y) along the edge, without turning it, then hold it still.",
          l.distance);
    case GuidedStep::kSpin:
      return fmt::format(
          "Mark a point on the floor under the robot's centre and a line at its front. Spin it "
          "{} whole turn{} {} about that point, stopping where the marks line up, then hold it "
          "still.",
          std::abs(l.turns), std::abs(l.turns) == 1.0 ? "" : "s",
          l.turns > 0 ? "counter-clockwise (seen from above)" : "clockwise (seen from above)");
  }
  return {};
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
                "With --guided: watch the motions live from --mouse, --serial or --replay");
  add_source_flags(cmd, w.source);
  cmd->add_flag("--no-push-y", w.no_push_y,
                "With --guided --live: skip the push along y (scales taken equal on both axes)");
}

void refuse_live_flags(const WizardArgs& args) {
  const SourceFlags& f = args.source;
  if (!f.mice.empty() || !f.serial.empty() || !f.replay.empty() || args.no_push_y) {
    throw io::Error(
        "--mouse, --serial, --replay and --no-push-y belong to --guided --live (the live guided "
        "calibration)");
  }
}

int run_wizard(const WizardArgs& args) {
  if (!args.guided) throw io::Error("--live needs --guided (the live guided calibration)");
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
  std::vector<GuidedStep> steps{GuidedStep::kPushX, GuidedStep::kPushY, GuidedStep::kSpin};
  if (args.no_push_y) steps.erase(steps.begin() + 1);
  std::vector<std::filesystem::path> inputs = source_files(args.source);
  inputs.emplace_back(args.config);
  io::refuse_output_onto_inputs(args.out, "--out", inputs);

  Terminal terminal;
  io::LiveHooks hooks;
  std::function<void()> poll_keys;
  hooks.stop = [] { return g_quit != 0; };
  hooks.tick = [&] {
    if (poll_keys) poll_keys();
  };
  hooks.warn = [](const std::string& text) { say("warning: {}\n", text); };
  LiveSource live = open_source(args.source, config, args.config, hooks);
  const double t0 = live.source->start_time();

  // Consensus: a sensor the nominal config has badly wrong (mirrored, say)
  // is left out of the estimate the checks judge.
  OdometryOptions options;
  options.estimator = EstimatorKind::kConsensus;
  options.use_wheels = false;
  options.max_gap = std::numeric_limits<double>::infinity();
  // No health monitor: the config is the nominal one being calibrated, and
  // its mount errors (a few mm at 0.1 m are a few percent in a spin) are
  // what the monitor's drift test would exclude sensors for.
  options.consensus.health.enabled = false;
  const auto odometry = io::make_odometry(config, args.config, t0, options);

  say("moa calibrate --guided --live: {} sensors of {}, from {}\n", config.names.size(),
      args.config, live.origin);
  say("Keys: Enter keeps a motion, r redoes it, q quits.\n");

  MotionWatcher watcher(config.array, limits);
  std::size_t current = 0;
  std::vector<std::vector<Eigen::Vector2d>> kept(3);
  std::optional<MotionSummary> pending;  // shown, waiting for a key
  bool announced_ready = false, announced_moving = false, quit = false;

  const auto begin_step = [&] {
    const GuidedStep step = steps[current];
    say("\nStep {} of {}: {}\n  {}\n  Hold the robot still...\n", current + 1, steps.size(),
        describe(step), instructions(step, limits));
    watcher.arm(step);
    announced_ready = announced_moving = false;
  };
  const auto on_key = [&](char key) {
    if (key == 'q' || key == 'Q') {
      quit = true;
      return;
    }
    if (!pending) return;
    const bool keep = key == '\n' || key == '\r' || key == 'y' || key == 'Y';
    const bool redo = key == 'r' || key == 'R' || (!pending->good() && keep);
    const bool force = key == 'k' || key == 'K';
    if (redo) {
      say("  Again.\n");
      pending.reset();
      begin_step();
    } else if ((keep && pending->good()) || force) {
      kept[static_cast<std::size_t>(pending->step)] = pending->totals;
      say("  Kept.\n");
      pending.reset();
      if (++current < steps.size()) begin_step();
    }
  };
  poll_keys = [&] {
    while (const auto key = terminal.key()) on_key(*key);
  };
  const auto on_step = [&](const OdometryStep& step) {
    auto summary = watcher.feed(step);
    if (watcher.state() == MotionWatcher::State::kReady && !announced_ready) {
      announced_ready = true;
      say("  Ready: go.\n");
    }
    if (watcher.state() == MotionWatcher::State::kMoving && !announced_moving) {
      announced_moving = true;
      say("  Moving...\n");
    }
    if (!summary) return;
    watcher.disarm();
    say("  Watched: {}\n", summarise(*summary));
    if (summary->good()) {
      say("  Good enough. Enter: keep it, r: redo\n");
    } else {
      say("  Not good enough:\n");
      for (const auto problem : summary->problems) {
        say("    - {}\n", explain(*summary, problem, limits));
      }
      if (summary->lifted_sensor >= 0) {
        say("    (sensor {})\n", config.names[static_cast<std::size_t>(summary->lifted_sensor)]);
      }
      say("  r or Enter: redo, k: keep it anyway\n");
    }
    pending = std::move(summary);
  };

  begin_step();
  double t_last = t0;
  while (!quit && current < steps.size() && g_quit == 0) {
    const auto row = live.source->next();
    if (!row) break;
    if (const auto e = odometry->push(*row, on_step)) {
      throw io::Error(
          fmt::format("{}: row at t = {} s: {}", live.where, row->t,
                      e == OdometryError::kRow ? describe(odometry->row_error()) : describe(*e)));
    }
    t_last = row->t;
    poll_keys();
  }
  (void)t_last;
  if (quit || g_quit != 0) {
    say("\nCalibration abandoned: nothing written.\n");
    return 1;
  }
  if (current < steps.size()) {
    say("\nThe data ended before the calibration was complete: nothing written.\n");
    return 1;
  }

  GuidedInput input;
  input.push_x = kept[0];
  if (!args.no_push_y) input.push_y = kept[1];
  input.spin = kept[2];
  input.distance = limits.distance;
  input.turns = limits.turns;
  const auto result = calibrate_guided(config.array, input, args.tolerances);
  if (const auto* e = std::get_if<CalibrationError>(&result)) {
    throw io::Error(fmt::format("the guided calibration failed: {}", describe(*e)));
  }
  const auto& cal = std::get<GuidedCalibration>(result);
  io::RobotConfig out = config;
  out.array = cal.calibrated;
  io::write_config(out, args.out);

  say("\nCalibrated from the kept motions ({} m pushes, {} turns); positions relative to the "
      "point the robot was spun about. Before -> after +- 1-sigma:\n",
      limits.distance, std::abs(limits.turns));
  print_mounts(config, cal);
  if (cal.centroid_shift.norm() > 0.003) {
    say("warning: the sensors' mean position moved by ({:.1f}, {:.1f}) mm from nominal: if the "
        "spin was not about the robot's centre, every position is shifted by that offset\n",
        cal.centroid_shift.x() * 1e3, cal.centroid_shift.y() * 1e3);
  }
  for (std::size_t i = 0; i < cal.push_misfit.size(); ++i) {
    if (cal.push_misfit[i] > 0.005 * limits.distance) {
      say("warning: {}: the two pushes disagree with one sensor frame by {:.1f} mm: were they "
          "perpendicular and without turning? Redo the calibration if unsure\n",
          config.names[i], cal.push_misfit[i] * 1e3);
    }
  }
  say("calibrated config written to {}\n", args.out);
  return 0;
}

}  // namespace moa::cli
