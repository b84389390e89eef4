// The exact calibration against measured poses of the robot (motion
// capture: camera.csv with theta; or positions only, a ceiling camera),
// with every sensor's latency and the
// reference's latency relative to the array (docs/calibration.md,
// "Against a camera").
//
// Clocks (formats/config.hpp): sensor i's row stamped t covers counts over
// an interval ending at t - L_i; a fix stamped t was captured at t - L_r.
// Only differences of clocks are seen: with d_i = L_i - L_r, the counts
// of sensor i over the true window (t_a - L_r, t_b - L_r] of two fixes
// stamped t_a < t_b are C_i(t_b + d_i) - C_i(t_a + d_i), C_i the
// sensor's cumulative counts on its stamped clock (each row spread
// uniformly over its interval, as IntervalAccumulator does). Gauge: the
// mean of the L_i stays as configured, L_r = mean(L_i) - mean(d_i).
//
// Model per window k (fixes merged to windows of at least `window` s):
//   c_ik = G_i A_i z_k + e_ik,   w_k dt_k = z_k + eta_k,
// z_k = (integral of the body-frame velocity, integral of omega) over the
// window (m, m, rad): what a body-fixed sensor integrates. From the fixes
// s..e of the window, w_k dt_k = (sum_j R(-theta_j') (p_{j+1} - p_j),
// theta_e - theta_s), theta_j' the mean heading of fixes j and j + 1:
// exact for the path through the fixes (straight between fixes at the
// fixes' rate: at 120 Hz and 1 m/s^2 a chord error of 1e-5 m), with no
// constant-twist approximation over the window (log(T_a^-1 T_b) would err
// by about omega a dt^3 / 12 under an acceleration a). Its noise is the
// fixes' (the end positions, and each heading times its step), not the
// counts': calibrate_exact's errors-in-variables model takes it
// (Sigma_w estimated), so a noisy reference does not shrink the scales.
// (Consecutive windows share a fix, so their reference errors are
// correlated, about -1/2 between neighbours; the model takes them as
// independent: the estimate stays consistent, its 1-sigma approximate.)
//
// 1. Coarse, from any start: the Pearson correlation, over lags L_r within
//    L_r0 +- max_offset on a grid of 5 ms, between the sensor points'
//    speeds by the reference, |z_xy + z_theta J p_i| / dt_k at the nominal
//    positions, and by the sensors, |c_ik| / (k_i dt_k) over the window
//    shifted by the lag (configured L_i), every window and sensor one pair.
//    A speed is what the mounts hardly change (yaw and mirroring not at
//    all), as Kalibr correlates angular rates. The peak, refined by a
//    parabola (calibration/lag_search.hpp); refused when it is at the edge
//    of the range or below min_correlation (another run).
// 2. Alternating, `iterations` times: the mounts by calibrate_exact at the
//    current d_i; then each d_i (three sweeps) by Gauss-Newton on
//      r_ik(d_i) = c_ik(d_i) - G_i A_i z~_k,
//      dr_ik/dd_i = g_i(t_b + d_i) - g_i(t_a + d_i)  (g_i: the row's count rate),
//    z~_k the other sensors' least-squares displacement at their offsets
//    (with three or more sensors: then r carries the counts' noise only,
//    not the reference's), else w_k dt_k; then the offset e common to all
//    sensors, d_i += e, by Gauss-Newton on r_k = w_k dt_k - P c_k(d + e)
//    (P the array's least squares) over windows of at least
//    `latency_window` s, weighted by the residuals' covariance S: a shift's
//    effect grows with the window (the velocity's change across it) while
//    the reference's noise per window does not (it is the end fixes').
// 3. Gauge, then 1-sigma: of d_i, sigma_i = (sum_k |dr_ik/dd|^2 / s_i^2)^-1/2,
//    s_i^2 the residual variance per axis; of L_r, the common offset's
//    (sum_k J_k^T S^-1 J_k)^-1/2 (J_k = P dc_k/de) with the mean's
//    sqrt(sum sigma_i^2) / N. A latency is seen only through accelerations
//    (the count rate changing across a window; constant velocity or a
//    steady turn leave every window unchanged by a shift): below
//    min_latency_information it is kept as configured, reported not seen.
#pragma once

#include <optional>
#include <span>
#include <variant>
#include <vector>

#include "moa/calibration/exact.hpp"
#include "moa/core/se2.hpp"

namespace moa {

/// One sensor's rows on its stamped clock as cumulative counts: the row
/// stamped t covers (max(previous row, t - max_row_interval), t], its
/// counts spread uniformly over it.
class CountsTrack {
 public:
  explicit CountsTrack(double max_row_interval = 0.05) : max_row_interval_(max_row_interval) {}
  /// Rows in increasing t; a row at a repeated t adds to the previous one.
  void add(double t, const Eigen::Vector2d& counts, bool flagged);
  bool empty() const { return knots_.size() < 2; }
  double front() const { return knots_.front().t; }
  double back() const { return knots_.back().t; }
  /// Counts over (a, b], front() <= a < b <= back().
  Eigen::Vector2d between(double a, double b) const;
  /// Count rate (counts/s) of the row covering t.
  Eigen::Vector2d rate(double t) const;
  /// A lift or overflow flag in a row that overlaps (a, b].
  bool flagged(double a, double b) const;

 private:
  struct Knot {
    double t;
    Eigen::Vector2d c;
    int flags;  // flagged rows up to t
  };
  std::size_t segment(double t) const;
  double max_row_interval_;
  std::vector<Knot> knots_;
};

/// A fix of the reference: stamp t (s) and the pose world_T_robot.
struct PoseFix {
  double t = 0.0;
  Pose2 pose;
};

/// A fix of a ceiling camera: stamp t (s) and the robot centre's position
/// in the world frame (m); no heading.
struct PositionFix {
  double t = 0.0;
  Eigen::Vector2d position{0.0, 0.0};
};

struct PoseReferenceOptions {
  double window = 0.2;  ///< s, least window between two fixes (the mounts, d_i)
  /// s, least window of the common offset's fit; halved (down to twice
  /// `window`) while that gives fewer than 20 windows (a short log)
  double latency_window = 2.0;
  double max_offset = 1.0;       ///< s, coarse search's range around the configured L_r
  double min_correlation = 0.5;  ///< least correlation at the coarse peak
  int iterations = 4;            ///< mounts / latencies alternations
  /// Least |dr/dd|^2 summed, over the residual variance, to fit a latency:
  /// 1/sigma^2 >= min_latency_information (s^-2): 1e6 is 1 ms.
  double min_latency_information = 1e6;
  ExactOptions exact;
};

enum class PoseReferenceError {
  kTooFewFixes,    ///< fewer than 20 windows within the sensors' rows
  kBadInput,       ///< stamps not increasing, values not finite
  kNoCorrelation,  ///< no correlation peak within the search range
  kCalibration,    ///< calibrate_exact refused (see `exact_error`)
};
const char* describe(PoseReferenceError error);

/// Positions only: the heading the fixes did not carry, from the array's
/// own rotation Theta(t) (integrated at the current mounts and latencies),
///   theta(t) = theta_0 + (1 + epsilon) Theta(t) + beta (t - t_0),
/// fitted to the camera's steps (header of calibrate_against_positions).
struct HeadingFit {
  double theta0 = 0.0, theta0_sigma = 0.0;          ///< rad, at the first fix used
  double rate_scale = 0.0, rate_scale_sigma = 0.0;  ///< epsilon, 1
  double drift = 0.0, drift_sigma = 0.0;            ///< beta, rad/s
  bool rate_scale_estimated = false;                ///< false: the array turned too little (kept 0)
  double rotation_range = 0.0;                      ///< rad, max - min of Theta over the fixes used
  double residual_rms = 0.0;  ///< m, per axis and window of the camera's steps
  int windows = 0;
  double yaw_gauge = 0.0;  ///< rad, the common yaw removed by the gauge in the last pass
};

struct PoseReferenceCalibration {
  ExactCalibration exact;
  std::vector<double> latency;        ///< L_i, s
  std::vector<double> latency_sigma;  ///< 1-sigma, s; 0 where kept as configured
  std::vector<bool> latency_estimated;
  double reference_latency = 0.0;        ///< L_r, s
  double reference_latency_sigma = 0.0;  ///< s
  double coarse_latency = 0.0;           ///< s, L_r of the coarse peak
  double correlation = 0.0;              ///< at the coarse peak
  int windows = 0;
  std::optional<HeadingFit> heading;  ///< positions only (calibrate_against_positions)
};

struct PoseReferenceFailure {
  PoseReferenceError error;
  std::optional<CalibrationError> exact_error;
  double correlation = 0.0;  ///< kNoCorrelation: the largest on the grid
};

/// The calibration of the header. `tracks` one per sensor of `nominal`,
/// `latency` the configured L_i, `reference_latency` the configured L_r,
/// `fixes` with a heading (motion capture), stamps increasing.
std::variant<PoseReferenceCalibration, PoseReferenceFailure> calibrate_against_poses(
    const SensorArray& nominal, std::span<const CountsTrack> tracks,
    std::span<const double> latency, std::span<const PoseFix> fixes, double reference_latency,
    const PoseReferenceOptions& options = {});

/// The same with positions only (a ceiling camera: camera.csv without
/// theta). The heading is not measured, so it is reconstructed, and the
/// robot frame's orientation is a gauge:
/// 0. Coarse: L_r by the correlation of the robot centre's speed,
///    |p_e - p_s| / dt, with the sensors' mean speed, mean_i |c_i| / (k_i dt)
///    over windows of fixes: the two differ by the rotation's share, but
///    neither yaw nor mirroring changes the latter (a least-squares speed
///    at a wrongly mirrored nominal mount would be no speed at all).
/// 1. Heading: the array's twist over each step between fixes, z_j = P c_j
///    (current mounts and offsets d_i), its rotations summed to Theta_j;
///    theta_0, epsilon and beta by Gauss-Newton on, per window s..e,
///      r = (p_e - p_s) - sum_j R(theta_j') z_j,xy,
///      theta_j' = theta_0 + (1 + epsilon) (Theta_j + z_j,theta / 2) + beta (t_j - t_0):
///    the direction of travel in the world against the body frame's. theta_0
///    and beta need translation only; epsilon (the array's rotation scale,
///    which its positions set: scaling every position by s scales the
///    array's rotation by 1/s, invisible to the counts' own fit) needs the
///    robot to turn: below 0.5 rad of range it is kept 0 and said.
///    Alternating with it, the common offset: the camera's positions against
///    the array's dead-reckoned path over segments of 5 s, each with its own
///    start and drift, the array's translation with a free 2x2 correction
///    (mounts still off), and a clock shift e moving the path along its
///    velocity (track_offset in the source); taken when its 1-sigma is
///    below the coarse grid's 5 ms, L_r <- L_r - e.
/// 2. calibrate_against_poses' mounts and per-sensor offsets on the fixes
///    with that heading (no coarse search, the offsets' mean kept: only
///    their differences are seen against the other sensors).
/// 3. Gauge: the robot frame turned by the circular mean delta of the
///    sensors' yaw changes, p_i <- R(-delta) p_i, yaw_i <- yaw_i - delta (the
///    nominal mean yaw kept). Steps 1-3 repeated until L_r moves less than
///    0.02 ms (each pass takes about 0.4 of the remaining error; at most 12).
std::variant<PoseReferenceCalibration, PoseReferenceFailure> calibrate_against_positions(
    const SensorArray& nominal, std::span<const CountsTrack> tracks,
    std::span<const double> latency, std::span<const PositionFix> fixes, double reference_latency,
    const PoseReferenceOptions& options = {});

}  // namespace moa
