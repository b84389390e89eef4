#include "moa/formats/config_init.hpp"

#include <fmt/core.h>

#include <array>
#include <cmath>

#include "moa/core/array.hpp"
#include "moa/formats/atomic_file.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/sensor_datasheets.hpp"

namespace moa::io {
namespace {

constexpr std::string_view kExplanation = R"(#
# Frames: the robot frame has x forward and y to the left, its origin at the
# point whose pose you want (usually the centre of rotation); angles are
# counter-clockwise, in radians.
#
# Each sensor:
#   name       the name mice.csv, the firmware or `moa live --mouse NAME=DEV` use
#   position   [x, y] of the sensor's centre in the robot frame, m
#   yaw        direction of the sensor's x axis in the robot frame, rad
#   cpi        the resolution the sensor is set to, counts per inch
#   scale      [x, y] per-axis correction of cpi (1 = as rated); calibration sets it
#   mirrored   true if the sensor's y axis is clockwise from its x axis seen
#              from above (a USB mouse: see docs/hardware.md)
#   max_speed  rated tracking speed, m/s (optional): faster readings are suspect
#   noise      velocity noise per axis, m/s (optional; quantisation alone if absent)
#
# Next: measure where the sensors really are and edit position, yaw and
# mirrored below; then calibrate (moa calibrate --method guided, see
# docs/calibration.md), which writes a corrected copy of this file, and run
# moa live --config THAT_FILE (docs/hardware.md).
)";

}  // namespace

std::optional<SensorPreset> find_sensor_preset(std::string_view name) {
  if (const SensorDatasheet* sheet = find_sensor_datasheet(name)) return sheet->preset;
  return std::nullopt;
}

std::string sensor_preset_names() {
  std::string out;
  for (const SensorDatasheet& s : sensor_datasheets()) {
    out += (out.empty() ? "" : ", ") + std::string(s.preset.name);
  }
  return out;
}

RobotConfig polygon_config(int n, double r, double theta, const SensorMount& prototype) {
  if (n < 2 || n > kMaxSensors) {
    throw Error(fmt::format("{} sensors: a layout needs 2 to {}", n, kMaxSensors));
  }
  if (!(std::isfinite(r) && r > 0.0)) {
    throw Error(fmt::format("radius {}: must be a positive number of metres", r));
  }
  if (!std::isfinite(theta)) throw Error(fmt::format("angle {}: must be a finite number", theta));
  RobotConfig config;
  config.array = regular_polygon(n, r, theta, prototype);
  // To the nanometre, so that a person reads 0 rather than 6.1e-18.
  for (int i = 0; i < n; ++i) {
    Eigen::Vector2d& p = config.array[i].position;
    p = (p * 1e9).array().round().matrix() / 1e9;
  }
  for (int i = 0; i < n; ++i) config.names.push_back(fmt::format("m{}", i + 1));
  return config;
}

std::string format_commented_config(const RobotConfig& config, std::string_view title) {
  std::string out;
  std::size_t begin = 0;
  while (begin <= title.size()) {
    const std::size_t end = std::min(title.find('\n', begin), title.size());
    out += fmt::format("# {}\n", title.substr(begin, end - begin));
    begin = end + 1;
  }
  out += kExplanation;
  return out + format_config(config);
}

void write_commented_config(const RobotConfig& config, std::string_view title,
                            const std::filesystem::path& path) {
  const std::string text = format_commented_config(config, title);
  AtomicFile file(path);
  file.stream() << text;
  file.commit();
}

}  // namespace moa::io
