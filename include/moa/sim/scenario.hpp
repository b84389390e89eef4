// A simulation scenario: the robot as it really is and as its user believes
// it to be, how it moves, its sensors, wheels, camera and faults. Read from
// YAML (docs/simulator.md has the format); the papers' set-ups are built in
// by name (the files under examples/scenarios/, compiled into the library).
//
// Errors name the file and line: "FILE:LINE: key 'x': what is wrong".
// Unknown keys are errors, as in the robot config.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "moa/formats/config.hpp"
#include "moa/sim/camera.hpp"
#include "moa/sim/clock.hpp"
#include "moa/sim/gyro.hpp"
#include "moa/sim/optical.hpp"
#include "moa/sim/trajectory.hpp"
#include "moa/sim/wheels.hpp"

namespace moa::sim {

inline constexpr int kScenarioVersion = 1;
/// s: the longest run, motion segment or duration a scenario may ask for (a day).
inline constexpr double kMaxScenarioDuration = 86400.0;
/// The most sensor frames a run may take (duration x frame_rate).
inline constexpr double kMaxScenarioFrames = 1e9;

struct Scenario {
  std::string name;
  std::string description;
  SensorModel sensor_model;
  io::RobotConfig nominal;  ///< what the user believes: robot.yaml
  io::RobotConfig truth;    ///< the simulated robot: robot.true.yaml
  Motion motion = TwistProgram{};
  double duration = 0.0;      ///< s, simulated time (whole rows of K frames)
  double truth_rate = 100.0;  ///< truth.csv rows per second, at least
  DriveModel drive;
  /// One per sensor, config order: mice.csv's latency and jitter
  /// (`true_sensors.NAME: {latency, jitter}`); robot.true.yaml has the latencies.
  std::vector<StreamTiming> sensor_timing;
  StreamTiming wheel_timing;  ///< wheels.csv's (`wheels: {latency, jitter}`)
  CameraModel camera;
  GyroSpec imu;
  std::vector<SensorFaults> faults;  ///< one per sensor, config order
  /// What the run's data cannot show to any estimator (`unobservable:`, a
  /// list of texts; the random worlds say it of themselves): faults.json
  /// carries it, and the random bench counts such worlds apart.
  std::vector<std::string> unobservable;

  /// Frames simulated: the duration in whole rows of K frames, rounded up.
  /// Throws io::Error beyond kMaxScenarioFrames.
  std::int64_t frame_count() const;
};

/// Parses scenario YAML; `source` names it in errors.
Scenario parse_scenario(std::string_view yaml, std::string_view source);
/// A built-in scenario by name, or else a YAML file by path.
Scenario load_scenario(std::string_view name_or_path);

/// Names of the built-in scenarios, sorted.
std::vector<std::string> builtin_scenarios();
/// The YAML text of a built-in scenario; empty if there is none by that name.
std::string_view builtin_scenario_text(std::string_view name);

}  // namespace moa::sim
