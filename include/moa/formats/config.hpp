// Robot configuration v1 (docs/formats/config.md): YAML in, YAML out, same schema.
//
//   version: 1
//   sensors:
//     - name: m1                 # unique, used by mice.csv
//       position: [0.07, 0.07]   # m, robot frame
//       yaw: 0.785398            # rad
//       cpi: 800
//       scale: [1.0, 1.0]        # optional
//       mirrored: false          # optional
//       max_speed: 0.3556        # optional, m/s
//       noise: 0.002             # optional (moa extension), m/s per axis
//       speed_scale:             # optional (moa extension): counted / true displacement
//         speeds: [0.5, 2.5]     # m/s, the sensor's ground speed, strictly increasing, 2..8 knots
//         ratios: [1.0, 0.9]     # each within [0.5, 1.5]; linear between, constant beyond
//   limits:                      # optional (moa extension): the motion prior
//     accel: 2.0                 # m/s^2, default 2
//     angular_accel: 20.0        # rad/s^2, default 20
//   imu:                         # optional (moa extension): the z gyro of imu.csv
//     scale: 1.0                 # reading per true rate
//     bias: 0.0                  # rad/s, reading at rest
//     noise_density: 0.00015     # rad/s/sqrt(Hz)
//     bias_random_walk: 0.0001   # rad/s/sqrt(s)
//     bias_sigma: 0.05           # rad/s, sd of the bias left
//     scale_sigma: 0.03          # sd of the scale error left
//     mount_yaw_sigma: 0.0035    # rad, sd of a sensor's yaw mount error
//     max_rate: 8.7              # rad/s, full scale
//     latency: 0.0               # s, a row's t minus the true end of its interval
//   camera:                      # optional (moa extension)
//     latency: 0.06              # s, a camera.csv t minus the true capture time
//   wheels:                      # optional (moa extension)
//     latency: 0.0               # s, a wheels.csv t minus the true end of its interval
//
// Unknown keys and missing required keys are errors that name the line,
// the key and the sensor; so are wrong types, non-finite numbers, cpi or
// scale <= 0, duplicate names and an unsupported version. The YAML is read
// by the strict reader shared with the simulator's scenarios (io/yaml.hpp).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "moa/core/array.hpp"
#include "moa/core/gyro.hpp"
#include "moa/core/motion_prior.hpp"

namespace moa::io {

/// s, the largest |latency| of a sensor (the synchroniser holds the rows of
/// the latencies' spread) and of the camera or wheels (another computer's
/// clock may be further off: moa calibrate --max-offset).
inline constexpr double kMaxSensorLatency = 1.0;
inline constexpr double kMaxStreamLatency = 60.0;

struct RobotConfig {
  std::vector<std::string> names;  ///< one per sensor, in array order
  SensorArray array;
  /// The robot's acceleration limits (key `limits`); unset: the defaults of
  /// RobotLimits. io::resolve_odometry_options gives them to the consensus's
  /// motion prior.
  std::optional<RobotLimits> limits = std::nullopt;
  /// The gyro (key `imu`); unset: the defaults of GyroOptions, used when a
  /// log has imu.csv.
  std::optional<GyroOptions> imu = std::nullopt;
  /// s, camera.csv's t minus the true capture time (key `camera: {latency}`);
  /// unset: 0, or --camera-latency.
  std::optional<double> camera_latency = std::nullopt;
  /// s, wheels.csv's t minus the true end of its interval (`wheels: {latency}`).
  std::optional<double> wheels_latency = std::nullopt;

  /// Index of the sensor called `name`, nullopt if there is none.
  std::optional<int> index_of(std::string_view name) const;
};

class YamlFields;
/// The key `speed_scale: {speeds: [m/s...], ratios: [...]}` of the map `f`
/// reads (a sensor of a config, a sensor of a scenario's true_sensors); the
/// identity when the key is absent. A refused table is an io::Error naming
/// the key, the knot and the bound (core/speed_scale.hpp).
SpeedScale parse_speed_scale(const YamlFields& f);

/// Parses YAML text; `source` names it in errors (usually the file path).
RobotConfig parse_config(std::string_view yaml, std::string_view source);

/// Sensor names are fields of mice.csv, parts of odometry.csv's `used`
/// column (joined by '+'), JSON keys and column names: only what all of them
/// carry unquoted, [A-Za-z0-9_.-]{1,32} (kSensorNameRule).
inline constexpr std::size_t kMaxSensorName = 32;
inline constexpr const char* kSensorNameRule =
    "1 to 32 characters among A-Z a-z 0-9 _ . - (what mice.csv, odometry.csv and JSON all carry)";
bool is_valid_sensor_name(std::string_view name);
/// Reads and parses a file; throws io::Error ("FILE: ...") on any problem.
RobotConfig read_config(const std::filesystem::path& path);

/// YAML text of a config; parse_config(format_config(c)) reproduces c exactly
/// (doubles written with enough digits to round-trip).
std::string format_config(const RobotConfig& config);
/// Writes a config file atomically.
void write_config(const RobotConfig& config, const std::filesystem::path& path);

}  // namespace moa::io
