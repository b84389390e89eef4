// Where live rows come from, for `moa live` and `moa calibrate --guided
// --live`: USB mice (--mouse), the serial board (--serial) or a recorded log
// played at its own pace (--replay). All three are io::FrameSource, so
// everything after this is the same.
#pragma once

#include <CLI/CLI.hpp>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "moa/formats/config.hpp"
#include "moa/sources/evdev.hpp"
#include "moa/sources/live.hpp"
#include "moa/sources/replay_reader.hpp"
#include "moa/sources/serial_reader.hpp"

namespace moa::cli {

struct SourceFlags {
  std::vector<std::string> mice;
  std::string serial;
  int baud = 500000;  ///< the firmware's (docs/firmware.md)
  std::string replay;
  double speed = 1.0;
  double start_timeout = 5.0;
  bool no_grab = false;
};

/// --mouse, --serial, --baud, --replay, --speed, --start-timeout, --no-grab.
void add_source_flags(CLI::App* cmd, SourceFlags& flags);

struct LiveSource {
  std::unique_ptr<io::FrameSource> source;
  io::EvdevReader* evdev = nullptr;    ///< set for --mouse
  io::SerialReader* serial = nullptr;  ///< set for --serial
  io::ReplayReader* replay = nullptr;  ///< set for --replay
  int mice = 0;                        ///< devices of --mouse
  std::string where;                   ///< for messages: "mice", the port, the log
  /// "3 mice (evdev)", the port, "replay of DIR": what a recording came from.
  std::string origin;
  /// Status text: how many sensors are alive, frames lost.
  std::string alive(const io::RobotConfig& config) const;
};

/// The files the source flags name (the mice's devices, the serial port,
/// the replayed log's files): what no output of the run may name.
std::vector<std::filesystem::path> source_files(const SourceFlags& flags);

/// Opens the one source the flags name; throws io::Error when none or more
/// than one is given, or the source cannot be opened.
LiveSource open_source(const SourceFlags& flags, const io::RobotConfig& config,
                       const std::string& config_path, const io::LiveHooks& hooks);

}  // namespace moa::cli
