// odometry.csv (docs/formats/log.md): the pipeline's steps as rows, and the
// rows read back with their selection columns typed.
//
//   t,x,y,theta,vx,vy,omega,sd_vx,sd_vy,sd_omega,source,used,excluded[,pxx,pxy,pyy,ptt]
//     [,scale_v,scale_omega,sd_scale_v,sd_scale_omega]
//
// used:     the sensors of the estimate, names joined by '+'
// excluded: name:reason[/flag...] joined by ';', reason a to_name(Exclusion)
//           word, flags the noise inflations (over-speed, low-squal, overflow)
// pxx..ptt: the EKF's pose covariance (m^2, m^2, m^2, rad^2) with camera fusion
// scale_*:  the EKF's dead-reckoning scales s_v, s_w and their sd (unit 1),
//           with camera fusion and the scale states (--ekf-scale)
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "moa/core/odometry.hpp"
#include "moa/formats/config.hpp"

namespace moa::io {

/// Writes a step per row; the file appears only on commit() (an exception
/// or a signal leaves no file behind).
class OdometryCsvWriter {
 public:
  /// `names`: the sensor names in config order; `fused`: adds the pose
  /// covariance columns; `scaled`: then the scale columns.
  OdometryCsvWriter(const std::filesystem::path& file, std::vector<std::string> names, bool fused,
                    bool scaled = false);
  /// The same rows to an open stream (stdout), flushed by flush() and commit().
  OdometryCsvWriter(std::FILE* stream, std::vector<std::string> names, bool fused,
                    bool scaled = false);
  ~OdometryCsvWriter();
  void write(const OdometryStep& step);
  /// The row of `step` at time `t` (s): step.sample is not read, so a copy
  /// of a step kept past its sink call (without its sample) can be written.
  void write(double t, const OdometryStep& step);
  void flush();
  void commit();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// One odometry.csv row. The selection fields are set only when the file has
/// the selection columns (has_selection()).
struct OdometryRow {
  double t = 0.0;
  Pose2 pose;
  Twist2 twist;
  std::optional<Eigen::Vector3d> sd;  ///< sd_vx, sd_vy, sd_omega
  std::optional<Source> source;
  SensorMask used = 0;
  /// Per sensor: kNone when used or not listed.
  std::array<Exclusion, kMaxSensors> excluded{};
  std::array<std::uint8_t, kMaxSensors> noise_flags{};
  /// Sensors listed in `used` or `excluded`.
  SensorMask listed = 0;
  std::optional<Eigen::Vector4d> pose_covariance;  ///< pxx, pxy, pyy, ptt
  std::optional<Eigen::Vector2d> scale;            ///< scale_v, scale_omega
  std::optional<Eigen::Vector2d> scale_sd;         ///< sd_scale_v, sd_scale_omega
};

/// Streams odometry.csv; sensor names must be the config's. Throws io::Error
/// with file, line and column on anything malformed.
class OdometryCsvReader {
 public:
  OdometryCsvReader(const std::filesystem::path& file, const RobotConfig& config,
                    std::string config_path);
  ~OdometryCsvReader();
  std::optional<OdometryRow> next();
  bool has_selection() const;
  const std::string& file() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// "inconsistent/over-speed": an exclusion and its noise flags as written.
std::string describe_exclusion(Exclusion reason, std::uint8_t noise_flags);

}  // namespace moa::io
