// diagnostics.csv (docs/formats/log.md): why each source was fused or left
// out, epoch by epoch, in the manner of PX4 EKF2's aid-source status. One
// row per epoch and source: `t,source,test_ratio,fused,reason,bias,scale`.
//   source      a sensor's name, `wheels` or `prior` (the motion prior)
//   test_ratio  the source's test statistic over its gate (1 = the gate;
//               above it the source contradicts the epoch's twist):
//               sensors r^T S^-1 r / q(1 - alpha, 2), wheels and prior
//               d^T (Cov + R)^-1 d / q(1 - alpha, 3) (docs/math.md); empty
//               where the source was not tested (the ls and sekimori
//               estimators, a stream that is absent)
//   fused       1 when the epoch's twist came from the source: a sensor
//               used, the wheels as source `wheels`, the prior as `hold`
//   reason      a sensor's exclusion (odometry.csv's reasons), else empty
//   bias, scale the gyro's calibration after the epoch (`imu` rows of the
//               consensus: GyroModel::bias() rad/s, scale()), else empty
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "moa/core/odometry.hpp"

namespace moa::io {

/// One row of diagnostics.csv.
struct DiagnosticsRow {
  double t = 0.0;           ///< s
  std::string source;       ///< sensor name, "wheels", "prior" or "imu" (the gyro)
  double test_ratio = 0.0;  ///< NaN where empty
  bool fused = false;
  std::string reason;
  std::optional<double> bias;   ///< rad/s, the gyro's after the epoch (imu rows)
  std::optional<double> scale;  ///< the gyro's, with bias
};

/// Reads a diagnostics.csv (columns by name); throws io::Error "FILE:LINE:
/// ..." for a missing column, a ratio that is neither empty nor a finite
/// number >= 0, a `fused` other than 0 or 1, or time going backwards.
std::vector<DiagnosticsRow> read_diagnostics_csv(const std::filesystem::path& file);

class DiagnosticsCsvWriter {
 public:
  /// `names`: the sensor names in config order; `selected`: the sensors written.
  DiagnosticsCsvWriter(const std::filesystem::path& file, std::vector<std::string> names,
                       SensorMask selected);
  ~DiagnosticsCsvWriter();
  void write(const OdometryStep& step);
  /// Renames the file into place (nothing appears without it).
  void commit();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace moa::io
