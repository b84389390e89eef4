// The sensors `moa config init --preset NAME` knows, with their data
// sheets' figures: what the robot config takes (cpi, rated speed) and what
// a person choosing, wiring and mounting them needs (cpi range, rated
// acceleration, frame rate, resolution error, working height), written
// into the config's comments.
#pragma once

#include <span>
#include <string>
#include <string_view>

#include "moa/core/sensor.hpp"

namespace moa::io {

struct SensorDatasheet {
  /// Name, default cpi (0: none, a flow chip's counts per inch depend on its
  /// height), rated speed (m/s; 0: given as a flow rate instead) and frame
  /// rate (frames/s; 0: not in the data sheet's summary).
  SensorPreset preset;
  double cpi_min;  ///< settable resolutions, counts per inch (0: none)
  double cpi_max;
  double cpi_step;
  double max_acceleration;  ///< rated, m/s^2 (0: not given)
  double max_flow_rate;     ///< rated, rad/s, for a flow chip (0: not one)
  double resolution_error;  ///< typical relative error of the cpi (0: not given)
  double height_min;        ///< working distance to the floor, m (0: a mouse's lens)
  double height_max;        ///< m (0: none given; infinity: no upper limit)
  double lift_off;          ///< height at which it stops tracking, m (0: not given)
  const char* interface;    ///< how moa reads it
  /// It reports a velocity, not counts (the OTOS): moa turns the velocity
  /// into counts of 1/cpi inch, so any cpi > 0 will do and the default is
  /// the preset's.
  bool velocity_sensor;
  /// rad/s, the full scale of its own z gyro (the OTOS), 0: it has none.
  /// With a gyro it can be the only sensor; `moa config init` writes the
  /// config's imu block with this max_rate.
  double gyro_full_scale;
};

/// Every known sensor, HDNS-2051 and ADNS-3080 first (moa's core presets).
std::span<const SensorDatasheet> sensor_datasheets();
/// The sensor called `name`, or null.
const SensorDatasheet* find_sensor_datasheet(std::string_view name);
/// Whether `cpi` is one of the sensor's settable resolutions.
bool cpi_settable(const SensorDatasheet& sheet, double cpi);
/// The figures as lines for a config's title (no '#', '\n' between lines).
std::string datasheet_lines(const SensorDatasheet& sheet);

}  // namespace moa::io
