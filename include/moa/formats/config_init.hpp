// A robot config to start from (moa config init): the sensors of a common
// layout, written with comments that say what each key means and what to do
// next, for a person to edit. The YAML itself is format_config()'s, so the
// file reads back exactly as any other config.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "moa/core/sensor.hpp"
#include "moa/formats/config.hpp"

namespace moa::io {

/// The rated figures of a sensor known by name ("HDNS-2051", "ADNS-3080",
/// "PMW3360", "PMW3389", "PMW3901", "PAA5100", "OTOS"; sensor_datasheets.hpp).
std::optional<SensorPreset> find_sensor_preset(std::string_view name);
/// The names find_sensor_preset() knows, comma separated (for messages).
std::string sensor_preset_names();

/// n sensors m1..mn at the vertices of a regular polygon of radius r (m),
/// the first at angle theta (rad), each aligned with the robot (yaw 0;
/// regular_polygon(), Kim & Lee eq. (1)), the other fields from `prototype`;
/// positions rounded to the nanometre so that a person reads 0, not 6e-18.
/// Throws io::Error if n is not 2..kMaxSensors or r, theta are not finite
/// with r > 0.
RobotConfig polygon_config(int n, double r, double theta, const SensorMount& prototype);

/// format_config(config) preceded by a comment block: `title` (one line, or
/// several separated by '\n'), then the frames, each key's unit and meaning,
/// and the next steps (calibration, moa live).
std::string format_commented_config(const RobotConfig& config, std::string_view title);

/// Writes format_commented_config() atomically (as write_config()).
void write_commented_config(const RobotConfig& config, std::string_view title,
                            const std::filesystem::path& path);

}  // namespace moa::io
