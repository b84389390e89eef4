// How the simulated robot moves: waypoint paths with trapezoidal velocity
// profiles, scripted twists, and a sum-of-sines excitation.
//
// The simulator advances in sensor frames of h = 1 / frame_rate seconds and
// holds the robot's twist constant within each frame; the truth is the exact
// SE(2) integral of those twists (moa::exp), so the sensors' counts (the
// measurement model applied to the same twists) and the truth agree to
// rounding. For waypoint paths the frame's twist is the one that carries the
// analytic pose at the frame's start to the analytic pose at its end
// (moa::twist_between), so the truth passes through every waypoint exactly.
#pragma once

#include <variant>
#include <vector>

#include "moa/core/se2.hpp"

namespace moa::sim {

/// A rest-to-rest trapezoidal profile of a coordinate s from 0 to 1 with
/// rate limit `max_rate` (1/s) and acceleration limit `max_accel` (1/s^2):
/// accelerate, cruise, decelerate (no cruise when the peak rate is not
/// reached: a triangle).
class Trapezoid {
 public:
  Trapezoid() = default;
  Trapezoid(double max_rate, double max_accel);
  double duration() const { return 2.0 * accel_time_ + cruise_time_; }
  /// s(t), clamped to [0, 1] outside [0, duration].
  double position(double t) const;

 private:
  double accel_ = 0.0;        ///< 1/s^2
  double peak_rate_ = 0.0;    ///< 1/s
  double accel_time_ = 0.0;   ///< s
  double cruise_time_ = 0.0;  ///< s
};

enum class Interpolation {
  kLinear,  ///< position along the straight line, heading linear: pure translation,
            ///< pure rotation, or both at once (an omnidirectional robot)
  kArc,     ///< constant body twist between the poses (SE(2) geodesic): a circular arc
};

struct PathLimits {
  double max_speed = 0.0;          ///< m/s, of the robot centre
  double max_rate = 0.0;           ///< rad/s
  double max_accel = 0.0;          ///< m/s^2
  double max_angular_accel = 0.0;  ///< rad/s^2
};

/// Poses (x m, y m, heading rad, world frame) visited in order, each segment
/// rest to rest with a trapezoidal profile that respects every limit, and a
/// pause (s) at rest on every waypoint, the first and the last included. A
/// Sekimori & Miyazaki Table 3 path is a list of pure translations and pure
/// rotations. Headings are taken literally: 0 then pi/2 turns by +pi/2.
class WaypointPath {
 public:
  /// `waypoints` >= 2, limits > 0 (checked by the scenario reader).
  WaypointPath(std::vector<Pose2> waypoints, Interpolation interpolation, PathLimits limits,
               double pause);

  double duration() const { return duration_; }
  /// The pose at time t (s from the start); the last waypoint exactly after the end.
  Pose2 pose(double t) const;
  const std::vector<Pose2>& waypoints() const { return waypoints_; }
  /// Time (s) at which the robot arrives at waypoint i (at rest).
  double arrival_time(std::size_t i) const;

 private:
  struct Segment {
    double start = 0.0;  ///< s, motion begins
    Trapezoid profile;
    Twist2 body;  ///< kArc: log(from^-1 to) (per unit of s)
  };
  std::vector<Pose2> waypoints_;
  Interpolation interpolation_;
  double pause_;
  std::vector<Segment> segments_;
  double duration_ = 0.0;
};

/// A list of constant twists (robot frame) held for given durations. With
/// acceleration limits (> 0) the twist moves toward each command at the
/// limited rate (per component for omega, along the vector for v); without,
/// it switches instantly (Kim & Lee's constant self-rotation starts at once).
struct TwistProgram {
  struct Segment {
    Twist2 twist;
    double duration = 0.0;  ///< s
  };
  std::vector<Segment> segments;
  double max_accel = 0.0;          ///< m/s^2, 0: instantaneous
  double max_angular_accel = 0.0;  ///< rad/s^2, 0: instantaneous

  double duration() const;
  /// The commanded twist at time t (zero after the last segment).
  Twist2 command(double t) const;
};

/// A calibration excitation: each twist component is an offset plus a sum of
/// sines a sin(2 pi f t + phase), the whole faded in and out over `fade`
/// seconds by sin^2 ramps so that the robot starts and ends at rest.
struct Excitation {
  struct Sine {
    double amplitude = 0.0;  ///< m/s or rad/s
    double frequency = 0.0;  ///< Hz
    double phase = 0.0;      ///< rad
  };
  std::vector<Sine> vx, vy, omega;
  Twist2 offset;
  double duration = 0.0;  ///< s
  double fade = 0.0;      ///< s

  Twist2 twist(double t) const;
};

using Motion = std::variant<WaypointPath, TwistProgram, Excitation>;

double duration(const Motion& motion);

/// Walks a motion frame by frame: the constant twist of each frame and the
/// pose at its end (world_T_robot, starting at the identity).
class MotionStepper {
 public:
  /// Starts at rest at the motion's first pose (a path's first waypoint,
  /// the identity otherwise).
  explicit MotionStepper(const Motion& motion);

  struct Step {
    Twist2 twist;  ///< robot frame, constant over the frame
    Pose2 pose;    ///< at the frame's end
  };
  /// The frame [t0, t1]; frames must be consecutive.
  Step advance(double t0, double t1);
  const Pose2& pose() const { return pose_; }

 private:
  const Motion& motion_;
  Pose2 pose_;
  Twist2 twist_;  ///< previous frame's twist (rate limiting)
};

}  // namespace moa::sim
