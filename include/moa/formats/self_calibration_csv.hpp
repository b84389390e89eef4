// The self-calibration's estimates over time (docs/formats/log.md,
// self-calibration.csv): `t,sensor,scale_x,scale_y,yaw_offset` (applied to
// the counts) `,filter_scale_x,filter_scale_y,filter_yaw_offset` (the
// filter's estimate; equal where it is applied)
// `,filter_sd_scale_x,filter_sd_scale_y,filter_sd_yaw_offset` (its standard
// deviations; the reader ignores them), one row per
// selected sensor about once a second (the first epoch at or after each
// whole second since the first epoch, and the last epoch), relative to the
// config (1, 1, 0: as configured; yaw_offset in rad).
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "moa/core/odometry.hpp"

namespace moa::io {

/// One row of self-calibration.csv.
struct SelfCalibrationRow {
  double t = 0.0;  ///< s, the epoch's time
  std::string sensor;
  SelfCalibrationEstimate estimate;  ///< applied: scale_x, scale_y; yaw_offset in rad
  /// The filter's estimate (filter_* columns; `estimate` when absent).
  SelfCalibrationEstimate filter;
};

/// Reads a self-calibration.csv (the columns by name, in any order); throws
/// io::Error "FILE:LINE: ..." for a missing column, a field that is not a
/// finite number, a scale <= 0 or a time earlier than the previous row's.
std::vector<SelfCalibrationRow> read_self_calibration_csv(const std::filesystem::path& file);

class SelfCalibrationCsvWriter {
 public:
  /// `names`: the sensor names in config order; `selected`: the sensors written.
  SelfCalibrationCsvWriter(const std::filesystem::path& file, std::vector<std::string> names,
                           SensorMask selected, double period = 1.0);
  ~SelfCalibrationCsvWriter();
  /// Writes the step's estimates when a period has passed (steps without them are ignored).
  void write(const OdometryStep& step);
  /// Writes the last step's estimates (if not written) and renames the file into place.
  void commit();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace moa::io
