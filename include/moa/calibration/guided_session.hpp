// The guided calibration as a session with live data: the motions asked for
// in turn (push along x, push along y unless skipped, spin), each watched in
// the nominal config's odometry (MotionWatcher, guided_steps.hpp), kept or
// redone at the user's word, and the kept motions' count totals handed to
// calibrate_guided (guided.hpp). No I/O: `moa calibrate --guided --live`
// reads the keys and prints; this decides.
//
// A motion that failed a check is redone unless kept by force. Data fed
// while a watched motion waits for the user's word is not watched: after the
// word, the robot must be still again before the next motion counts.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "moa/calibration/guided.hpp"
#include "moa/calibration/guided_steps.hpp"
#include "moa/core/odometry.hpp"

namespace moa {

/// What the user is to do for `step`, in words: where to start, how far or
/// how many turns, in which direction (from `limits`).
std::string instructions(GuidedStep step, const MotionLimits& limits);

/// What a guided calibration's result warns of, one sentence each: the
/// sensors' mean position moved more than 3 mm from nominal (the spin was
/// perhaps not about the robot's centre, which shifts every position); a
/// sensor's two pushes disagree with one sensor frame by more than 0.5 % of
/// `distance` (m; were they perpendicular, without turning?). `names`: the
/// sensors' names, in the calibration's order. The offline method (`moa
/// calibrate --method guided`) and the live session say the same.
std::vector<std::string> guided_result_warnings(const GuidedCalibration& calibration,
                                                double distance,
                                                const std::vector<std::string>& names);

/// The odometry options the session's epochs are to come from: consensus
/// (a sensor the nominal config has badly wrong, mirrored say, is left out
/// of the estimate the checks judge), no wheels, no gyro (its rows calibrate
/// it; they are not fused), no limit on silences, and no
/// health monitor (the nominal config's mount errors, a few mm at 0.1 m, are
/// a few per cent in a spin: what its drift test would exclude sensors for).
OdometryOptions guided_session_odometry_options();

class GuidedSession {
 public:
  /// What an epoch changed.
  enum class Event : std::uint8_t {
    kNone,
    kReady,    ///< the robot has been still: the motion may start
    kMoving,   ///< the motion started
    kWatched,  ///< the motion ended: pending() says how it went
  };

  /// `nominal`: the config the fed odometry runs with; `limits` validated
  /// (MotionLimits::validate). Without `push_y` the push along y is skipped.
  GuidedSession(const SensorArray& nominal, const MotionLimits& limits, bool push_y);

  /// The motions asked for, in order.
  const std::vector<GuidedStep>& steps() const { return steps_; }
  /// The index in steps() of the motion asked for now; steps().size() once
  /// complete.
  std::size_t current() const { return current_; }
  bool complete() const { return current_ >= steps_.size(); }
  /// The motion watched, waiting for keep() or redo(); nullptr if none.
  const MotionSummary* pending() const { return pending_ ? &*pending_ : nullptr; }

  /// Starts watching for the current motion (the first, or again).
  void begin_step();
  /// One epoch of the nominal odometry. Each of kReady and kMoving is said
  /// once per attempt.
  Event feed(const OdometryStep& epoch);
  /// Keeps the pending motion and moves on; a motion that failed a check is
  /// kept only with `force`. False (nothing changes) when there is nothing
  /// to keep or the motion failed and `force` is not given.
  bool keep(bool force);
  /// Drops the pending motion and watches for the same motion again. False
  /// when nothing is pending.
  bool redo();

  /// The kept motions as calibrate_guided takes them; call once complete().
  GuidedInput input() const;

 private:
  MotionLimits limits_;
  MotionWatcher watcher_;
  std::vector<GuidedStep> steps_;
  std::size_t current_ = 0;
  std::vector<std::vector<Eigen::Vector2d>> kept_;  ///< totals by GuidedStep
  std::optional<MotionSummary> pending_;
  bool said_ready_ = false, said_moving_ = false;
};

}  // namespace moa
