#include "live_source.hpp"

#include <fmt/core.h>

#include "moa/formats/error.hpp"
#include "moa/runs/odometry_run.hpp"
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
  auto* replay = cmd->add_option("--replay", f.replay,
                                 "Play a log directory (mice.csv) at the pace it was recorded, "
                                 "as if it came from the sensors (demos, tests)")
                     ->check(CLI::ExistingPath);
  mouse->excludes(serial)->excludes(replay);
  serial->excludes(replay);
  cmd->add_option("--baud", f.baud, "Baud rate of --serial")->needs(serial)->capture_default_str();
  cmd->add_option("--speed", f.speed, "Playback speed of --replay (2: twice real time)")
      ->needs(replay)
      ->check(kPositive)
      ->capture_default_str();
  cmd->add_option("--start-timeout", f.start_timeout,
                  "Seconds to wait for the serial device's HELLO and first DATA")
      ->check(kPositive)
      ->capture_default_str();
  cmd->add_flag("--no-grab", f.no_grab,
                "Do not grab the mice (EVIOCGRAB): the desktop cursor follows them too");
}

LiveSource open_source(const SourceFlags& f, const io::RobotConfig& config,
                       const std::string& config_path, const io::LiveHooks& hooks) {
  const int given = !f.mice.empty() + !f.serial.empty() + !f.replay.empty();
  if (given != 1) {
    throw io::Error(
        "give one of --mouse NAME=DEV (one per mouse), --serial DEV or --replay LOGDIR");
  }
  LiveSource s;
  if (!f.mice.empty()) {
    std::vector<io::EvdevDevice> devices;
    for (const auto& b : parse_bindings(f.mice, "--mouse")) {
      const auto index = config.index_of(b.name);
      if (!index) {
        throw io::Error(fmt::format("--mouse {}={}: no sensor '{}' in {}", b.name, b.target, b.name,
                                    config_path));
      }
      devices.push_back({b.name, b.target, *index});
    }
    if (static_cast<int>(devices.size()) < config.array.size()) {
      hooks.warning(fmt::format("{} of the {} sensors of {} have a mouse; the others read as still",
                                devices.size(), config.array.size(), config_path));
    }
    io::EvdevOptions options;
    options.grab = !f.no_grab;
    auto reader = std::make_unique<io::EvdevReader>(devices, options, hooks);
    s.evdev = reader.get();
    s.source = std::move(reader);
    s.where = "mice";
    s.mice = static_cast<int>(devices.size());
    s.origin = fmt::format("{} mice (evdev)", f.mice.size());
  } else if (!f.serial.empty()) {
    io::SerialOptions options;
    options.baud = f.baud;
    options.start_timeout = f.start_timeout;
    auto reader = std::make_unique<io::SerialReader>(f.serial, config, options, hooks);
    s.serial = reader.get();
    s.source = std::move(reader);
    s.where = f.serial;
    s.origin = f.serial;
  } else {
    io::ReplayOptions options;
    options.speed = f.speed;
    // The option's name is the flag's: "--speed: must be > 0, is -1".
    if (const auto e = options.validate()) throw io::Error(fmt::format("--{}", e->message()));
    auto reader = std::make_unique<io::ReplayReader>(f.replay, config, options, hooks);
    s.replay = reader.get();
    s.source = std::move(reader);
    s.where = f.replay;
    s.origin = fmt::format("a replay of {}", f.replay);
  }
  return s;
}

std::vector<std::filesystem::path> source_files(const SourceFlags& f) {
  std::vector<std::filesystem::path> files;
  for (const auto& binding : parse_bindings(f.mice, "--mouse")) files.emplace_back(binding.target);
  if (!f.serial.empty()) files.emplace_back(f.serial);
  if (!f.replay.empty()) {
    const auto log = io::resolve_log(f.replay).files();
    files.insert(files.end(), log.begin(), log.end());
  }
  return files;
}

std::string LiveSource::alive(const io::RobotConfig& config) const {
  if (evdev) return fmt::format("mice {}/{} alive", evdev->alive(), mice);
  if (serial) {
    const bool fresh = serial->seconds_since_data() < 1.0;
    return fmt::format("sensors {}/{} alive, {} frames lost",
                       fresh ? serial->hello().names.size() : 0, config.names.size(),
                       serial->stats().lost_frames);
  }
  return fmt::format("replay, {} rows", replay ? replay->rows() : 0);
}

}  // namespace moa::cli
