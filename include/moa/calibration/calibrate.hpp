// Calibration of the sensor mounts: the vocabulary shared by the three
// methods (Kim & Lee, exact, guided) and the pairing of mice counts with a
// reference twist.
//
// What calibration estimates, per sensor i (docs/formats/config.md):
//   counts_i / dt = M_i v + omega q_i,          v, omega: robot twist (robot frame)
//   M_i = k_i diag(sx_i, f_i sy_i) R(yaw_i)^T   2x2, counts per metre,
//   q_i = M_i J p_i                             counts per radian,
// k_i = cpi_i / 0.0254 (nominal, never changed: the scale absorbs it),
// f_i = -1 when mirrored. The continuous parameters are
//   (px, py, yaw, sx, sy)  in m, m, rad, 1, 1   (MountParameter order),
// and mirrored is a discrete one, decided by the sign of det M_i.
//
// A reference sample pairs the counts accumulated over an interval
// (t - dt, t] with the robot twist averaged over the same interval (wheel
// odometry in wheels.csv). The pairing integrates each mice row over the
// reference intervals (IntervalAccumulator): a row's counts are spread over
// the intervals it overlaps in proportion to the overlap, the rule the
// Synchroniser uses for its epochs. Integrating over the reference's own
// intervals, rather than resampling both onto a common grid, keeps the two
// sides of every equation averages over exactly the same time.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "moa/core/array.hpp"
#include "moa/core/synchronise.hpp"

namespace moa {

/// The continuous mounting parameters calibration estimates, in vector order.
enum class MountParameter : int { kPositionX = 0, kPositionY, kYaw, kScaleX, kScaleY };
inline constexpr int kMountParameters = 5;
using MountVector = Eigen::Matrix<double, kMountParameters, 1>;
using MountMatrix = Eigen::Matrix<double, kMountParameters, kMountParameters>;

/// Why a calibration could not be computed (data errors come back as values).
enum class CalibrationError {
  kTooFewSensors,   ///< fewer than two sensors
  kTooManySensors,  ///< more than kMaxSensors, or samples of another array size
  kInvalidMount,    ///< a nominal cpi or scale not positive and finite
  kTooFewSamples,   ///< fewer usable samples than the method needs
  kNoMotion,        ///< the reference twists are all zero
  kBadInput,        ///< a distance, turn count or count total not usable
};
const char* describe(CalibrationError error);

/// "position x", "position y", "yaw", "scale x", "scale y".
const char* describe(MountParameter parameter);

/// (px, py, yaw, sx, sy) of a mount.
MountVector mount_parameters(const SensorMount& mount);
/// `mount` with (px, py, yaw, sx, sy) replaced; cpi, mirrored and the rest kept.
SensorMount with_mount_parameters(SensorMount mount, const MountVector& parameters);

/// One reference sample: counts over (t - dt, t] and the robot twist
/// averaged over the same interval.
struct CalibrationSample {
  ArraySample mice;  ///< counts in each sensor's own frame; t, dt of the interval
  Twist2 reference;  ///< robot frame, m/s and rad/s (wheel odometry)
};

/// True when a sample can enter a calibration: dt positive and finite, the
/// reference and all n sensors' counts finite, no lift or overflow flag.
bool usable_sample(const CalibrationSample& sample, int n_sensors);

/// Checks the nominal array: 2..kMaxSensors sensors with positive, finite cpi and scale.
std::optional<CalibrationError> check_nominal(const SensorArray& nominal);

/// Sums consecutive samples into `groups` measurements of about equal total
/// duration (groups >= samples.size() or 0: returned as they are). The
/// model is linear in the twist, so a sum of samples is again a sample:
/// counts add, dt add, the reference is the dt-weighted mean twist. This is
/// how a long log becomes Kim & Lee's M measurements.
std::vector<CalibrationSample> merge_samples(const std::vector<CalibrationSample>& samples,
                                             int groups);

/// The sensor matrix M = k diag(sx, f sy) R(yaw)^T split into its parts.
struct SensorMatrixParts {
  double yaw = 0.0;                 ///< rad, wrapped to (-pi, pi]
  Eigen::Vector2d scale{1.0, 1.0};  ///< per-axis correction of k
  bool mirrored = false;            ///< f = -1, i.e. det M < 0
};

/// Splits a measured 2x2 sensor matrix (counts per metre) into yaw, scale
/// and mirroring, given the nominal k (counts per metre). mirrored is the
/// sign of det M; the yaw is that of the rotation nearest diag(1, f) M / k
/// (polar decomposition), and each scale the projection of the row of
/// diag(1, f) M / k on that rotation's row. Exact when M has the model's
/// form; a least-squares start for a non-linear fit otherwise. nullopt when
/// M is singular (|det M| <= 1e-12 k^2) or not finite.
std::optional<SensorMatrixParts> decompose_sensor_matrix(const Eigen::Matrix2d& m,
                                                         double counts_per_metre);

/// p = J^-1 M^-1 q = -J M^-1 q: the position whose rotation response is q
/// (q = M J p, counts per radian) for the sensor matrix M.
Eigen::Vector2d position_from_rotation_response(const Eigen::Matrix2d& m, const Eigen::Vector2d& q);

/// Integrates mice rows over given reference intervals.
///
/// The reference times b_0 < b_1 < ... < b_m define m intervals
/// (b_{k-1}, b_k] (b_0 only opens the first, as the first wheels.csv row has
/// no start). A row of sensor i at t covers (a, t], a = max(previous row of
/// i (or t0), t - max_row_interval), and is spread over the intervals in
/// proportion to overlap; a row with an empty interval goes whole into the
/// interval containing t. Built once per calibration; allocates.
class IntervalAccumulator {
 public:
  /// `times` must be strictly increasing (at least two for one interval);
  /// `t0` is the time from which each sensor's first row accumulates.
  IntervalAccumulator(int n_sensors, double t0, std::vector<double> times,
                      double max_row_interval = 0.05);

  /// Adds a row; returns the error instead when the row is invalid (then
  /// nothing changes).
  std::optional<RowError> add(const SensorRow& row);

  /// The intervals that lie wholly within the span the rows cover,
  /// [t0, last row time]: intervals outside it would count motion the rows
  /// did not see. Their `t` is b_k and `dt` b_k - b_{k-1}; `index` gives k - 1.
  struct Interval {
    int index = 0;
    ArraySample sample;
  };
  std::vector<Interval> covered() const;

  int size() const { return static_cast<int>(samples_.size()); }

 private:
  int n_;
  double t0_;
  double max_row_interval_;
  std::vector<double> times_;
  std::vector<ArraySample> samples_;  // one per interval
  std::vector<double> last_t_;        // per sensor
  double last_row_t_;
};

}  // namespace moa
