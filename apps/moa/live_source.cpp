#include "live_source.hpp"

#include <fmt/core.h>

#include "moa/formats/error.hpp"
#include "moa/sources/i2c_dev.hpp"
#include "moa/sources/otos_registers.hpp"
#include "odometry_options.hpp"
#include "sensor_binding.hpp"

namespace moa::cli {

void add_source_flags(CLI::App* cmd, SourceFlags& f) {
  auto* mouse = cmd->add_option("--mouse", f.mice,
                                "NAME=DEV: sensor NAME of the config is the evdev device DEV "
                                "(prefer /dev/input/by-path/...-event-mouse); repeat per mouse");
  auto* serial = cmd->add_option("--serial", f.serial,
                                 "Serial port of the acquisition microcontroller "
                                 "(docs/serial-protocol.md)");
  auto* otos = cmd->add_option(
      "--otos", f.otos,
      "[NAME=]/dev/i2c-N[:ADDR]: SparkFun OTOS unit on I2C adapter N at ADDR (default 0x17), "
      "sensor NAME of the config (without NAME=: the config's sensor at this flag's place among "
      "the --otos); repeat per unit, each on its own bus or multiplexer channel; the first "
      "unit's gyro is the imu stream (docs/hardware.md)");
  auto* replay = cmd->add_option("--replay", f.replay,
                                 "Play a log directory (mice.csv; for moa live its wheels.csv "
                                 "and imu.csv too, unless --no-wheels, --no-imu; for the live "
                                 "guided calibration its imu.csv, the gyro calibrated from the "
                                 "spin) at the pace it was recorded, as if it came from the "
                                 "sensors (demos, tests)")
                     ->check(CLI::ExistingPath);
  mouse->excludes(serial)->excludes(replay)->excludes(otos);
  serial->excludes(replay)->excludes(otos);
  otos->excludes(replay);
  cmd->add_option("--otos-rate", f.otos_rate,
                  "Polls of every --otos unit per second (25 to 416.7, the unit's loop)")
      ->needs(otos)
      ->check(CLI::Range(io::OtosOptions::kMinRate, io::otos::kLoopRate))
      ->capture_default_str();
  cmd->add_flag("--otos-no-imu-calibration", f.otos_no_imu_calibration,
                "Do not calibrate the --otos units' gyro and accelerometer at start (it takes "
                "about 0.6 s with the robot still)")
      ->needs(otos);
  cmd->add_option("--baud", f.baud, "Baud rate of --serial")->needs(serial)->capture_default_str();
  cmd->add_option("--speed", f.speed,
                  "Playback speed of --replay (2: twice real time; 0.001 to 1000000)")
      ->needs(replay)
      ->check(kPositive)
      ->check(finite_within(io::ReplayOptions::kMinSpeed, io::ReplayOptions::kMaxSpeed))
      ->capture_default_str();
  cmd->add_option("--start-timeout", f.start_timeout,
                  "Seconds to wait for the serial device's HELLO and first DATA")
      ->check(kPositive)
      ->capture_default_str();
  cmd->add_flag("--no-grab", f.no_grab,
                "Do not grab the mice (EVIOCGRAB): the desktop cursor follows them too");
}

io::LiveSourceSpec source_spec(const SourceFlags& f, const io::RobotConfig& config,
                               const std::string& config_path) {
  const int given = !f.mice.empty() + !f.serial.empty() + !f.otos.empty() + !f.replay.empty();
  if (given != 1) {
    throw io::Error(
        "give one of --mouse NAME=DEV (one per mouse), --serial DEV, --otos [NAME=]/dev/i2c-N "
        "(one per unit) or --replay LOGDIR");
  }
  io::LiveSourceSpec spec;
  for (const auto& b : parse_bindings(f.mice, "--mouse")) {
    const auto index = config.index_of(b.name);
    if (!index) {
      throw io::Error(fmt::format("--mouse {}={}: no sensor '{}' in {}", b.name, b.target, b.name,
                                  config_path));
    }
    spec.mice.push_back({b.name, b.target, *index});
  }
  for (std::size_t k = 0; k < f.otos.size(); ++k) {
    const std::string& arg = f.otos[k];
    std::string name;
    std::string target = arg;
    if (const std::size_t eq = arg.find('='); eq != std::string::npos) {
      const auto bound = parse_bindings({arg}, "--otos");
      name = bound[0].name;
      target = bound[0].target;
    } else if (k < config.names.size()) {
      name = config.names[k];
    } else {
      throw io::Error(fmt::format("--otos {}: no NAME= and {} has only {} sensors for {} --otos",
                                  arg, config_path, config.names.size(), f.otos.size()));
    }
    const auto index = config.index_of(name);
    if (!index) {
      throw io::Error(fmt::format("--otos {}: no sensor '{}' in {}", arg, name, config_path));
    }
    for (const auto& unit : spec.otos) {
      if (unit.name == name) {
        throw io::Error(fmt::format("--otos {}: sensor '{}' given twice", arg, name));
      }
    }
    io::OtosDevice unit;
    unit.name = name;
    unit.sensor = *index;
    try {
      unit.bus = io::parse_i2c_address(target, io::otos::kDefaultAddress);
    } catch (const io::Error& e) {
      throw io::Error(fmt::format("--otos {}", e.what()));
    }
    spec.otos.push_back(unit);
  }
  spec.otos_options.rate = f.otos_rate;
  spec.otos_options.start.calibrate_imu = !f.otos_no_imu_calibration;
  spec.evdev.grab = !f.no_grab;
  spec.serial = f.serial;
  spec.serial_options.baud = f.baud;
  spec.serial_options.start_timeout = f.start_timeout;
  spec.replay = f.replay;
  spec.replay_options.speed = f.speed;
  if (!f.replay.empty()) {
    // The option's name is the flag's: "--speed: must be > 0, is -1".
    if (const auto e = spec.replay_options.validate()) {
      throw io::Error(fmt::format("--{}", e->message()));
    }
  }
  return spec;
}

}  // namespace moa::cli
