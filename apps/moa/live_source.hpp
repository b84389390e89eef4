// The flags of a live source, for `moa live` and `moa calibrate --guided
// --live`: USB mice (--mouse), the serial board (--serial), SparkFun OTOS
// units on I2C (--otos) or a recorded log played at its own pace (--replay). The library opens it
// (runs/live_source.hpp).
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "moa/formats/config.hpp"
#include "moa/runs/live_source.hpp"

namespace moa::cli {

struct SourceFlags {
  std::vector<std::string> mice;
  std::string serial;
  int baud = 500000;              ///< the firmware's (docs/firmware.md)
  std::vector<std::string> otos;  ///< [NAME=]/dev/i2c-N[:ADDR]
  double otos_rate = io::OtosOptions{}.rate;
  bool otos_no_imu_calibration = false;
  std::string replay;
  double speed = 1.0;
  double start_timeout = 5.0;
  bool no_grab = false;
};

/// --mouse, --serial, --baud, --otos, --otos-rate, --otos-no-imu-calibration,
/// --replay, --speed, --start-timeout, --no-grab.
void add_source_flags(CLI::App* cmd, SourceFlags& flags);

/// The source the flags name. Throws io::Error naming the flag when none or
/// more than one source is given, a --mouse or --otos names no sensor of
/// `config`, an --otos address is not one, or --speed is not positive and
/// finite. An --otos without NAME= is the config's sensor at its place among
/// the --otos flags (the first --otos the first sensor).
io::LiveSourceSpec source_spec(const SourceFlags& flags, const io::RobotConfig& config,
                               const std::string& config_path);

}  // namespace moa::cli
