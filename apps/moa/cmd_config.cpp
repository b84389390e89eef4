// moa config init: a commented robot.yaml for a common layout, to edit.
#include <fmt/core.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "commands.hpp"
#include "moa/core/array.hpp"
#include "moa/formats/config_init.hpp"
#include "moa/formats/csv.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/sensor_datasheets.hpp"

namespace moa::cli {
namespace {

struct ConfigInitArgs {
  std::string layout;
  std::optional<int> sensors;
  std::optional<double> radius;
  double theta_deg = 0.0;
  std::vector<std::string> sensor_specs;
  std::optional<double> cpi;
  std::string preset;
  std::string out;
  bool force = false;
};

double finite_option(const std::string& flag, std::string_view text) {
  const auto parsed = io::parse_number(text);
  if (const auto* why = std::get_if<std::string>(&parsed)) {
    throw io::Error(fmt::format("{}: {}", flag, *why));
  }
  return std::get<double>(parsed);
}

/// NAME=X,Y,YAW_DEG[,mirrored]: metres, metres, degrees.
void add_sensor(const std::string& spec, const SensorMount& prototype, io::RobotConfig& config) {
  const auto fail = [&spec](const std::string& why) {
    throw io::Error(fmt::format("--sensor {}: {} (expected NAME=X,Y,YAW_DEG[,mirrored]: m, m, deg)",
                                spec, why));
  };
  const std::size_t eq = spec.find('=');
  if (eq == std::string::npos || eq == 0) fail("no NAME=");
  std::vector<std::string> fields;
  std::size_t begin = eq + 1;
  while (true) {
    const std::size_t comma = spec.find(',', begin);
    fields.push_back(spec.substr(begin, comma - begin));
    if (comma == std::string::npos) break;
    begin = comma + 1;
  }
  if (fields.size() != 3 && fields.size() != 4) fail(fmt::format("{} fields", fields.size()));
  if (fields.size() == 4 && fields[3] != "mirrored") fail(fmt::format("'{}'", fields[3]));
  SensorMount m = prototype;
  m.position = {finite_option("--sensor " + spec, fields[0]),
                finite_option("--sensor " + spec, fields[1])};
  m.yaw = to_radians(finite_option("--sensor " + spec, fields[2]));
  m.mirrored = fields.size() == 4;
  config.names.push_back(spec.substr(0, eq));
  std::vector<SensorMount> mounts(config.array.mounts().begin(), config.array.mounts().end());
  mounts.push_back(m);
  config.array = SensorArray(std::move(mounts));
}

int run_config_init(const ConfigInitArgs& a) {
  SensorMount prototype;
  std::string sensor_kind;
  const io::SensorDatasheet* sheet = nullptr;
  if (!a.preset.empty()) {
    sheet = io::find_sensor_datasheet(a.preset);
    if (sheet == nullptr) {
      throw io::Error(
          fmt::format("--preset {}: unknown (known: {})", a.preset, io::sensor_preset_names()));
    }
    prototype.cpi = sheet->preset.cpi;
    if (sheet->preset.max_speed > 0.0) prototype.max_speed = sheet->preset.max_speed;
    sensor_kind = fmt::format("{} ", sheet->preset.name);
  }
  if (a.cpi) {
    if (!(std::isfinite(*a.cpi) && *a.cpi > 0.0)) {
      throw io::Error(
          fmt::format("--cpi {}: must be a positive number of counts per inch", *a.cpi));
    }
    if (sheet != nullptr && sheet->cpi_step > 0.0 && !io::cpi_settable(*sheet, *a.cpi)) {
      throw io::Error(fmt::format("--cpi {}: the {} is set from {:g} to {:g} cpi in steps of {:g}",
                                  *a.cpi, sheet->preset.name, sheet->cpi_min, sheet->cpi_max,
                                  sheet->cpi_step));
    }
    prototype.cpi = *a.cpi;
  } else if (a.preset.empty()) {
    throw io::Error("give --cpi (the sensors' counts per inch) or --preset");
  } else if (sheet->cpi_step <= 0.0 && !sheet->velocity_sensor) {
    throw io::Error(fmt::format(
        "--preset {}: a flow chip has no resolution to set, its counts per inch depend on its "
        "height over the floor: push the robot a measured distance, divide the counts by it "
        "(docs/hardware.md) and give --cpi",
        sheet->preset.name));
  }

  io::RobotConfig config;
  std::string title;
  if (!a.sensor_specs.empty()) {
    if (!a.layout.empty() || a.sensors || a.radius) {
      throw io::Error(
          "--sensor lists the sensors one by one: leave out --layout, --sensors, --radius");
    }
    for (const std::string& spec : a.sensor_specs) add_sensor(spec, prototype, config);
    // One sensor takes its rotation from a gyro: a sensor with its own may be alone.
    const bool own_gyro = sheet != nullptr && sheet->gyro_full_scale > 0.0;
    if (config.names.size() < (own_gyro ? 1u : 2u)) {
      throw io::Error("--sensor: give at least 2 sensors");
    }
    title = fmt::format("{} {}sensors at {} cpi, placed one by one", config.names.size(),
                        sensor_kind, prototype.cpi);
  } else {
    if (a.layout.empty()) throw io::Error("give --layout polygon, or the sensors with --sensor");
    if (!a.sensors) throw io::Error("--layout polygon needs --sensors N");
    if (!a.radius) throw io::Error("--layout polygon needs --radius METRES");
    if (*a.sensors < 2 || *a.sensors > kMaxSensors) {
      throw io::Error(fmt::format("--sensors {}: must be 2 to {}", *a.sensors, kMaxSensors));
    }
    if (!(std::isfinite(*a.radius) && *a.radius > 0.0)) {
      throw io::Error(fmt::format("--radius {}: must be a positive number of metres", *a.radius));
    }
    if (!std::isfinite(a.theta_deg)) {
      throw io::Error(
          fmt::format("--theta-deg {}: must be a finite number of degrees", a.theta_deg));
    }
    // Reduced to a turn first (fmod is exact): beyond about 1e16 deg the
    // sensors' angles, theta + k 360 / N, would round to one value and the
    // sensors coincide.
    config = io::polygon_config(*a.sensors, *a.radius, to_radians(std::fmod(a.theta_deg, 360.0)),
                                prototype);
    title = fmt::format(
        "{} {}sensors at {} cpi on a regular polygon of radius {} m,\n"
        "the first at {} deg from the robot's x axis, all aligned with the robot (yaw 0)",
        *a.sensors, sensor_kind, prototype.cpi, *a.radius, a.theta_deg);
  }

  const std::filesystem::path out(a.out);
  std::error_code ec;
  if (!a.force && std::filesystem::exists(out, ec)) {
    throw io::Error(fmt::format("{}: exists; pass --force to replace it", a.out));
  }
  if (std::filesystem::is_directory(out, ec))
    throw io::Error(fmt::format("{}: is a directory", a.out));
  if (sheet != nullptr) title += "\n" + io::datasheet_lines(*sheet);
  if (sheet != nullptr && sheet->gyro_full_scale > 0.0) {
    config.imu = GyroOptions{};
    config.imu->max_rate = sheet->gyro_full_scale;
  }
  io::write_commented_config(config, "robot.yaml written by moa config init:\n" + title, out);
  fmt::print(
      "moa config init: {} sensors written to {}; edit it, then calibrate "
      "(docs/calibration.md)\n",
      config.names.size(), a.out);
  return 0;
}

}  // namespace

void add_config(CLI::App& app, Action& action) {
  auto* config = app.add_subcommand("config", "Robot configs (robot.yaml)");
  config->require_subcommand(1);
  auto args = std::make_shared<ConfigInitArgs>();
  auto* init = config->add_subcommand(
      "init", "Write a commented robot.yaml for a common layout, to edit and calibrate");
  init->add_option("--layout", args->layout, "Sensor layout")->check(CLI::IsMember({"polygon"}));
  init->add_option("--sensors", args->sensors, "Number of sensors of the layout (2 to 16)");
  init->add_option("--radius", args->radius, "Distance of each sensor from the robot's origin, m");
  init->add_option("--theta-deg", args->theta_deg,
                   "Angle of the first sensor from the robot's x axis, deg (default 0)");
  init->add_option("--sensor", args->sensor_specs,
                   "One sensor: NAME=X,Y,YAW_DEG[,mirrored] (m, m, deg); repeat for each")
      ->take_all()
      ->allow_extra_args(false);
  init->add_option("--cpi", args->cpi, "Resolution of every sensor, counts per inch");
  init->add_option("--preset", args->preset,
                   "Sensor model: sets cpi (unless --cpi) and the rated max_speed: " +
                       io::sensor_preset_names());
  init->add_option("--out", args->out, "The robot.yaml to write")->required();
  init->add_flag("--force", args->force, "Replace --out if it exists");
  init->callback([&action, args] { action = [args] { return run_config_init(*args); }; });
}

}  // namespace moa::cli
