// Log format v1 (docs/formats/log.md): a directory of CSV files.
//
// Every reader finds columns by header name, skips '#' comment lines
// anywhere, ignores unknown extra columns, and throws io::Error as
// "FILE:LINE: what is wrong" for: a missing required column, a wrong
// number of fields, a field that is not a number (or not an integer where
// one is required), NaN or infinity, time going backwards, an unknown
// sensor name, squal outside 0..255, an empty file (no header).
#pragma once

#include <array>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "moa/core/se2.hpp"
#include "moa/core/synchronise.hpp"
#include "moa/formats/config.hpp"

namespace moa::io {

/// Yields timestamped per-sensor counts, in non-decreasing time. The log
/// reader, and later the live readers, implement it, so that everything
/// downstream of it is the same for files and devices.
class FrameSource {
 public:
  virtual ~FrameSource() = default;
  /// Time from which the first row of each sensor accumulates (s).
  virtual double start_time() = 0;
  /// The next row, nullopt at the end. Throws io::Error on bad input.
  virtual std::optional<SensorRow> next() = 0;
};

/// Streams mice.csv (columns t, sensor, dx, dy, optional squal, flags);
/// memory does not grow with the file's length.
class MiceReader : public FrameSource {
 public:
  /// `path` is the log directory or the mice.csv file itself; sensor names
  /// are resolved against `config`.
  MiceReader(const std::filesystem::path& path, const RobotConfig& config);
  ~MiceReader() override;
  double start_time() override;
  std::optional<SensorRow> next() override;
  /// mice.csv as named in errors, and the line of the last row read.
  const std::string& file() const;
  std::size_t line() const;
  /// Rows read so far per sensor, in config order (a sensor with none by the
  /// end never reported).
  const std::vector<std::size_t>& rows_per_sensor() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct WheelRow {
  double t = 0.0;  ///< s, end of the averaging interval
  Twist2 twist;    ///< robot frame, m/s and rad/s
};
/// A gyro row (imu.csv): the rate about the robot's z axis (rad/s,
/// counter-clockwise seen from above), averaged over the interval since the
/// previous row, ending at t (s), as the gyro reports it (before its
/// config's scale, bias and latency).
struct ImuRow {
  double t = 0.0;   ///< s, end of the averaging interval
  double gz = 0.0;  ///< rad/s
  /// The simulator's truth (optional column `faults`, moa extension): 1 when
  /// a gyro fault acted on the row (stuck, saturated, its bias stepped), 0
  /// otherwise; only the oracle reads it.
  std::uint8_t faults = 0;
};
struct CameraRow {
  double t = 0.0;                        ///< s
  Eigen::Vector2d position{0, 0};        ///< m, world frame
  std::optional<double> theta;           ///< rad
  std::optional<Eigen::Vector2d> sigma;  ///< m, (sx, sy)
};
struct TruthRow {
  double t = 0.0;
  Pose2 pose;  ///< world_T_robot
};

/// Streams a CSV of one of the record types above.
template <class Row>
class RowReader {
 public:
  explicit RowReader(const std::filesystem::path& file);
  ~RowReader();
  std::optional<Row> next();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};
using WheelsReader = RowReader<WheelRow>;   ///< wheels.csv: t,vx,vy,omega
using CameraReader = RowReader<CameraRow>;  ///< camera.csv: t,x,y[,theta][,sx,sy]
using ImuReader = RowReader<ImuRow>;        ///< imu.csv: t,gz
using TruthReader = RowReader<TruthRow>;    ///< truth.csv: t,x,y,theta

/// Reads a whole file of rows (evaluation and calibration, not streaming).
template <class Row>
std::vector<Row> read_all(const std::filesystem::path& file) {
  RowReader<Row> reader(file);
  std::vector<Row> rows;
  while (auto row = reader.next()) rows.push_back(*row);
  return rows;
}

/// Writes odometry.csv: t,x,y,theta,vx,vy,omega, then `extra_columns`.
/// The file appears only on commit(); an exception leaves no file behind.
class OdometryWriter {
 public:
  OdometryWriter(const std::filesystem::path& file, std::vector<std::string> extra_columns = {});
  /// Rows to an open stream (stdout for `moa live`); commit() flushes it.
  OdometryWriter(std::FILE* stream, std::vector<std::string> extra_columns);
  ~OdometryWriter();
  /// One row; `extra` must hold one value per extra column (already text).
  void write(double t, const Pose2& pose, const Twist2& twist,
             const std::vector<std::string>& extra = {});
  /// One row whose extra values come already joined, each after a comma:
  /// ",v1,v2,...", one per extra column. The caller vouches that no value
  /// holds a comma or a line break (OdometryCsvWriter, from numbers, fixed
  /// words and checked names); the other checks are write()'s.
  void write_joined(double t, const Pose2& pose, const Twist2& twist, std::string_view extra);
  /// write_joined() in two steps, the extra values written in place: checks
  /// the row and writes its seven numbers, then returns where the caller
  /// writes the extra values (",v1,v2,...", at most `max_extra` chars);
  /// end_row() takes the end of what it wrote.
  char* begin_row(double t, const Pose2& pose, const Twist2& twist, std::size_t max_extra);
  void end_row(char* end);
  void commit();
  /// Flushes a stream (no-op for a file, which appears on commit()).
  void flush();

 private:
  void header();
  void check(const std::array<double, 7>& values);
  char* put_numbers(const std::array<double, 7>& values, std::size_t max_extra);
  void put_row(const std::array<double, 7>& values, std::string_view extra);
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace moa::io
