// The guided calibration's motions as they happen: which motion is asked
// for, when it starts and ends, and whether it is good enough for
// calibrate_guided (guided.hpp) or why not. No I/O: `moa calibrate --guided
// --live` feeds it the odometry of the nominal config and talks to the user.
//
// A motion is watched in the nominal config's estimate (good to a few per
// cent before calibration, which is all the checks need): it starts at the
// first epoch that moves (|v| > still_speed or |omega| > still_rate) after
// the robot was still, and ends once the robot has been still for
// still_time. Its count totals (what calibrate_guided takes) run from the
// last still epoch before the start to the end, so the still epochs add
// only their noise.
//
// Checks, in the frame of the robot at the motion's start (x forward):
//   push along x (y): d = sum of v dt (the start frame, the estimated
//     rotation ignored); its length |d_x| (|d_y|) within distance_tolerance
//     of the distance asked for ("too short", "too long"); its direction
//     within max_off_axis of the axis ("not along x"); each sensor's
//     cumulative counts, which a straight push moves along a straight line
//     whatever the sensor's mount, within max_deviation (scaled to metres
//     by |d|) of their chord ("not straight"); the heading changed by at
//     most max_heading_change ("turned while pushing": the method assumes
//     (d, 0), guided.hpp).
//   spin: the total angle (sum of omega dt, not wrapped) within
//     turn_tolerance turns of the turns asked for ("too few / too many
//     turns"); the robot's origin, which a spin about it leaves in place and
//     a spin about c carries round a circle of diameter 2|c|, never farther
//     than 2 max_spin_offset from its start ("off-centre spin").
//   both: no sensor point faster than max_speed_fraction of its rated
//     max_speed, nor an overflow reported ("too fast"); no lift reported.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "moa/core/array.hpp"
#include "moa/core/odometry.hpp"
#include "moa/core/se2.hpp"

namespace moa {

enum class GuidedStep : std::uint8_t { kPushX, kPushY, kSpin };
/// "push along x", "push along y", "spin".
const char* describe(GuidedStep step);

struct MotionLimits {
  double distance = 1.0;             ///< m, each push (as the user is told)
  double turns = 3.0;                ///< whole turns of the spin (sign: direction)
  double distance_tolerance = 0.15;  ///< relative, of the push length
  double max_off_axis = 0.0873;      ///< rad (5 deg), push direction from the axis
  double max_deviation = 0.01;       ///< m, path from the straight line
  /// rad (15 deg), turning during a push, as the nominal mounts see it.
  /// Generous on purpose: before calibration, relative mount errors e (yaw
  /// in rad, scale) show as a false turn of about e x distance / r for
  /// sensors at r from the centre: 2 % at 0.1 m gives ~10 deg over 1 m
  /// (docs/live.md). Smaller turns are the straight edge's to prevent;
  /// after the calibration the push misfit shows them.
  double max_heading_change = 0.2618;
  double turn_tolerance = 0.1;      ///< turns
  double max_spin_offset = 0.02;    ///< m, spin centre from the robot's origin
  double max_speed_fraction = 0.8;  ///< of each sensor's rated max_speed
  double still_speed = 0.005;       ///< m/s
  double still_rate = 0.05;         ///< rad/s
  double still_time = 0.5;          ///< s of stillness that ends a motion
  /// nullopt when usable, else the first field out of its bounds, the bound
  /// and the value (core/options_check.hpp).
  OptionCheck validate() const;
};

enum class MotionProblem : std::uint8_t {
  kTooShort,
  kTooLong,
  kOffAxis,
  kNotStraight,
  kTurned,
  kTooFewTurns,
  kTooManyTurns,
  kOffCentre,
  kTooFast,
  kLifted,
};

struct MotionSummary {
  GuidedStep step = GuidedStep::kPushX;
  double duration = 0.0;                     ///< s, start to end (the final still time included)
  Eigen::Vector2d displacement{0.0, 0.0};    ///< m, in the start frame
  double rotation = 0.0;                     ///< rad, sum of omega dt
  double deviation = 0.0;                    ///< m, largest distance from the straight line
  double spin_offset = 0.0;                  ///< m, half the origin's largest excursion
  double top_speed = 0.0;                    ///< m/s, fastest sensor point
  std::optional<double> speed_fraction;      ///< of the rated max_speed, when rated
  int fast_sensor = -1, lifted_sensor = -1;  ///< a sensor that was too fast / lifted
  bool overflow = false;
  std::vector<Eigen::Vector2d> totals;  ///< count totals per sensor
  std::vector<MotionProblem> problems;
  bool good() const { return problems.empty(); }
};

/// One line on the motion: "1.003 m along x, 2 mm off the line, turned 0.1 deg".
std::string summarise(const MotionSummary& motion);
/// Why `problem` makes the motion unusable, and what to do: one sentence.
std::string explain(const MotionSummary& motion, MotionProblem problem, const MotionLimits& limits);

class MotionWatcher {
 public:
  enum class State : std::uint8_t {
    kIdle,      ///< not watching (between steps, waiting for the user)
    kSettling,  ///< waiting for still_time of stillness
    kReady,     ///< still: the motion may start
    kMoving,    ///< a motion is under way
  };

  /// `nominal`: the config the odometry fed to feed() runs with.
  MotionWatcher(const SensorArray& nominal, const MotionLimits& limits);

  /// Watches for a motion of `step`, once the robot has been still.
  void arm(GuidedStep step);
  void disarm() { state_ = State::kIdle; }
  State state() const { return state_; }
  GuidedStep step() const { return step_; }

  /// One epoch of the nominal odometry; the motion's summary when it ended.
  std::optional<MotionSummary> feed(const OdometryStep& epoch);

 private:
  bool still(const OdometryStep& epoch) const;
  MotionSummary finish() const;

  SensorArray nominal_;
  MotionLimits limits_;
  State state_ = State::kIdle;
  GuidedStep step_ = GuidedStep::kPushX;
  double still_for_ = 0.0;
  double t_start_ = 0.0, t_last_ = 0.0;
  Pose2 start_;                        ///< world_T_robot where the motion starts
  std::vector<Eigen::Vector2d> path_;  ///< origin positions in the start frame
  Eigen::Vector2d body_{0.0, 0.0};     ///< sum of v dt (start frame, rotation ignored)
  std::vector<std::vector<Eigen::Vector2d>> count_paths_;  ///< cumulative counts per epoch
  std::vector<Eigen::Vector2d> totals_;
  double rotation_ = 0.0, top_speed_ = 0.0;
  double worst_fraction_ = -1.0;
  int fast_sensor_ = -1, lifted_sensor_ = -1;
  bool overflow_ = false;
};

}  // namespace moa
