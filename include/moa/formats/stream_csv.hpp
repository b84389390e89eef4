// Writes the robot's streams of a live run (`moa live --streams --record`)
// as a log's wheels.csv (t,vx,vy,omega), imu.csv (t,gz) and camera.csv (t,x,y,theta,sx,sy;
// empty where a fix has no heading or no standard deviations), log format
// v1 (docs/formats/log.md). Numbers are written as the shortest text that
// reads back as the same double, so the log replays to exactly the rows fed.
// Each file appears on commit() only, and only if a row of its stream came.
#pragma once

#include <filesystem>
#include <memory>
#include <string>

#include "moa/core/odometry.hpp"
#include "moa/formats/atomic_file.hpp"
#include "moa/formats/log.hpp"

namespace moa::io {

class StreamCsvWriter {
 public:
  /// `dir`: the log directory; `comment` becomes a '#' line before the header.
  StreamCsvWriter(std::filesystem::path dir, std::string comment);
  void write(const WheelRow& row);
  void write(const ImuRow& row);
  void write(const CameraFix& fix);
  /// Completes the files written to; throws io::Error on failure.
  void commit();
  std::size_t wheel_rows() const { return wheel_rows_; }
  std::size_t fixes() const { return fixes_; }
  std::size_t imu_rows() const { return imu_rows_; }

 private:
  std::filesystem::path dir_;
  std::string comment_;
  std::unique_ptr<AtomicFile> wheels_, imu_, camera_;
  std::size_t wheel_rows_ = 0, imu_rows_ = 0, fixes_ = 0;
};

}  // namespace moa::io
