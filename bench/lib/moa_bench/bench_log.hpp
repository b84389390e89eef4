// What `moa bench --replay` and `moa bench --live` run on: a generated log
// of four sensors (noise-free counts of a smooth drive) in a scratch
// directory.
#pragma once

#include <cstddef>
#include <filesystem>

#include "moa/formats/config.hpp"

namespace moa::bench {

/// A directory that is removed with everything in it when this goes away
/// (unless kept).
class ScratchDir {
 public:
  ScratchDir(const std::filesystem::path& parent, bool keep = false);
  ~ScratchDir();
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  bool keep_;
};

/// Four HDNS-2051 at 45/135/225/315 deg, 0.1 m from the centre, x axis
/// radial (Sekimori & Miyazaki's layout).
io::RobotConfig four_sensors();

/// robot.yaml and mice.csv (t,sensor,dx,dy,squal,flags) in `dir`, a row per
/// sensor every 1/row_rate s from t = 0 over `duration` s: each row holds
/// the counts of the twist at the middle of its interval (the measurement
/// model), the fraction carried to the next row so that the counts never
/// drift from the motion. Returns the rows written.
std::size_t write_log(const io::RobotConfig& config, double duration, double row_rate,
                      const std::filesystem::path& dir);

}  // namespace moa::bench
