// What an odometry run did, in counts a user can check against odometry.csv:
// epochs by the source of their twist, sensor-epochs by the reason a sensor
// was left out, the camera fixes, the warnings, and a verdict. Filled step by
// step by io::run_odometry (and so by `moa odometry`, the experiments and
// Python); `moa odometry` prints it with text().
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "moa/core/odometry.hpp"
#include "moa/core/robust_estimate.hpp"
#include "moa/formats/odometry_csv.hpp"

namespace moa::io {

/// Values of Source and of Exclusion (kNone, "used", included).
inline constexpr std::size_t kSourceCount = static_cast<std::size_t>(Source::kHold) + 1;
inline constexpr std::size_t kExclusionCount = static_cast<std::size_t>(Exclusion::kCommonMode) + 1;

/// An epoch's heading source: "gyro" when its rotation was the gyro's
/// (SourceTests::gyro_fused), else its twist's source (mice, wheels, hold).
inline const char* heading_source(const RobustEstimate& e) {
  return e.tests.gyro_fused ? "gyro" : to_name(e.source);
}

struct RunSummary {
  /// Epochs written (rows of odometry.csv).
  std::size_t epochs = 0;
  /// Epochs by the source of their twist, indexed by Source: the `source`
  /// column of odometry.csv.
  std::array<std::size_t, kSourceCount> epochs_by_source{};
  /// Sensor-epochs by what happened to the sensor, indexed by Exclusion
  /// (kNone: used), over the configured sensors: the `used` and `excluded`
  /// columns of odometry.csv.
  std::array<std::size_t, kExclusionCount> sensor_epochs{};
  FixCounts fixes;
  /// `moa live --pose-out`: lines made and, of them, dropped (the reader
  /// absent, slow or gone; runs/pose_stream.hpp). Both 0 without a stream.
  std::size_t pose_lines = 0, pose_lines_dropped = 0;
  /// The gyro (imu.csv with the consensus estimator): epochs with a gyro
  /// reading (an `imu` row of diagnostics.csv) and, of all epochs, those
  /// whose heading (rotation) was the gyro's (SourceTests::gyro_fused; the
  /// others take it from their `source`). Both 0 without a gyro.
  std::size_t gyro_epochs = 0, heading_from_gyro = 0;
  /// The gyro's calibration after the last epoch (GyroModel): bias c + b
  /// (rad/s) and scale k (1 + s), each with its sd.
  struct GyroCalibration {
    double bias = 0, bias_sd = 0;    ///< rad/s
    double scale = 1, scale_sd = 0;  ///< reading per true rate
    /// s, the rows' latency learnt and the config's (imu.latency)
    double latency = 0, latency_sd = 0, configured_latency = 0;
    long bias_resets = 0;  ///< bias steps found (GyroModel::bias_resets)
    static GyroCalibration of(const GyroModel& g) {
      return {g.bias(),    g.bias_sd(),    g.scale(),           g.scale_sd(),
              g.latency(), g.latency_sd(), g.options().latency, g.bias_resets()};
    }
  };
  /// Set by add(step) when the step carries the gyro's model.
  std::optional<GyroCalibration> gyro;
  /// What the caller should tell the user (a selected sensor that never
  /// reported, a self-calibration that ran away), one sentence each.
  std::vector<std::string> warnings;

  /// The rule: usable when at least one epoch was written and at most
  /// kMaxHeldFraction of them were held (Source::kHold: neither a sensor nor
  /// the wheels measured the motion; the twist is the last one, its
  /// covariance grown, so the pose of such an epoch is a guess). Warnings do
  /// not change the verdict: they say where to look.
  static constexpr double kMaxHeldFraction = 0.01;
  /// The gyro's latency learnt is reported as differing from the config's
  /// beyond this many of its sds.
  static constexpr double kLatencySds = 3.0;
  bool usable() const;
  /// Why usable() is what it is, one sentence.
  std::string verdict() const;

  /// Counts one step over the `sensors` configured sensors.
  void add(const OdometryStep& step, int sensors);
  /// Counts one row of odometry.csv as written from such a step (the report
  /// reads the file): the same counts as add(step) gave, for the columns the
  /// file has (no `source` column: no epoch by source).
  void add(const OdometryRow& row, int sensors);
  /// Lines (each ending in '\n'): epochs by source, exclusions by reason
  /// (the reasons that occurred), fixes when any, the pose stream's lines
  /// when any, the gyro when any epoch had a reading (gyro_line()), the
  /// verdict.
  std::string text() const;
  /// "gyro: bias B rad/s (sd D), scale S (sd D), heading from the gyro in N
  /// of M epochs (P %)" (the calibration's part only when gyro is set);
  /// empty when no epoch had a gyro reading.
  std::string gyro_line() const;
};

}  // namespace moa::io
