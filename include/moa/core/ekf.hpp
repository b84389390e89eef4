// An extended Kalman filter on the planar pose (x, y, theta), world frame:
// dead reckoning from the estimator's twists, corrected by absolute fixes
// (Sekimori & Miyazaki Section 4.3: a ceiling camera that gives position).
//
// Prediction over dt with twist xi = (vx, vy, omega) and its covariance Q:
//   pose' = pose * exp(xi dt)                         (exact SE(2) step)
//   t'    = t + R(theta) V(phi) v dt,  theta' = theta + phi,  phi = omega dt
//   F = d pose'/d pose = [[I, R(theta) J d], [0, 1]],  d = V(phi) v dt
//   G = d pose'/d xi   = [[R(theta) V(phi) dt, R(theta) V'(phi) v dt^2], [0, 0, dt]]
//   P' = F P F^T + G (Q + Q_floor) G^T
// Q_floor is a process-noise floor for what the twist covariance does not
// hold (resolution errors that are systematic over a run), white in time:
// Q_floor(dt) = diag(floor^2) (0.01 s / dt), so that splitting a step in
// two leaves the pose covariance of the whole step unchanged.
//
// Update with a fix z (position, optionally heading), noise R:
//   1. innovation y = z - h(pose), heading component wrapped to (-pi, pi]
//   2. S = H P H^T + R
//   3. gate: reject when y^T S^-1 y > gate (Mahalanobis, chi-square quantile)
//   4. K = P H^T S^-1
//   5. pose += K y
//   6. P = (I - K H) P (I - K H)^T + K R K^T   (Joseph form: stays symmetric
//      positive definite despite rounding)
//
// Late fixes: the filter keeps the last kHistory prediction steps. A fix
// captured at t_fix earlier than the newest prediction is applied at its own
// time: the state is rolled back to the step that contains t_fix, predicted
// to t_fix, updated, and re-predicted with the stored twists. A fix older
// than the history is refused (counted), never applied at the wrong time.
// Recovery: when max_consecutive_rejections fixes in a row fail the gate,
// the dead reckoning has left the camera behind (a systematic drift the
// process noise did not hold); P gains diag(y y^T) and the fix is applied.
//
// Scale states (EkfOptions::estimate_scale, `moa odometry --ekf-scale`):
// the state becomes (x, y, theta, s_v, s_w) and the twist integrated is
// S xi, S = diag(s_v, s_v, s_w): s_v corrects the mice's linear resolution
// (cpi, a common scale error), s_w their rotation (radius, or the same
// resolution through omega). Prediction, with G = G(S xi) as above:
//   pose' = pose * exp(S xi dt),  s' = s + w,  w ~ N(0, diag(rw^2) dt)
//   F5 = [[F(S xi), d pose'/d s], [0, I]]
//   d pose'/d s_v = G (vx, vy, 0)^T,  d pose'/d s_w = G (0, 0, omega)^T
//   P' = F5 P F5^T + diag(G S (Q + Q_floor) S G^T, rw^2 dt)
// The scales start at 1 with sd scale_sd (5 %) and walk by
// scale_random_walk (1e-3 per sqrt(second): 0.8 % over a minute). The update
// has H = [I 0]: fixes observe the pose only, the scales move through
// their correlation with it (the rows F5 builds):
//   - s_v needs translation between fixes: its column of F5 is the distance
//     the robot travelled, R(theta) V v dt; at rest or turning in place it
//     gets nothing.
//   - s_w needs rotation and heading information: with heading fixes
//     directly (theta' - theta = s_w omega dt); from positions alone only
//     through the geometry, the heading error a turn leaves (s_w - 1) phi
//     shows as a sideways drift d theta x (travel) in the translation after
//     it. During an in-place turn a position fix says nothing about either.
// Rollback keeps working: a Step stores the scales and the 5x5 covariance
// before it (history 128 x 352 bytes = 45 KB on the Cortex-M4F, 26.6 KB
// before; 384 bytes a step on x86-64, where Eigen aligns Vector2d), and
// re-prediction uses the corrected scales. Off, the scale rows of the
// covariance are zero and the pose filter's arithmetic is the 3x3 one
// (outputs byte-identical). Measured (docs/math.md, "Camera fusion"): a
// robot whose mice over-estimate rotation by 3 % (sensors 3 mm further out)
// has heading RMS 0.041 rad without the scale states and 0.012 with them
// (seeds 101-105), s_w found to 0.9708-0.9712 +- 0.0055 (true 0.9709); on a
// calibrated robot they cost ~0.003 rad heading RMS, so they are opt-in.
//
// Fixed-size matrices only: no allocation per step.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <optional>

#include "moa/core/options_check.hpp"
#include "moa/core/ring.hpp"
#include "moa/core/se2.hpp"

namespace moa {

/// The twist (s_v vx, s_v vy, s_w omega).
Twist2 scaled_twist(const Twist2& twist, const Vec2& scale);
/// d pose' / d (s_v, s_w) (3x2) of integrate_exact(pose, scaled_twist(twist, scale), dt):
/// G(scaled twist) [[vx, 0], [vy, 0], [0, omega]].
Mat<3, 2> exact_step_scale_jacobian(const Pose2& pose, const Twist2& twist, const Vec2& scale,
                                    real dt);

struct EkfOptions {
  /// Augments the state with the dead reckoning's scales (s_v, s_w): the
  /// twist integrated is (s_v vx, s_v vy, s_w omega). Off: the pose filter
  /// alone, arithmetic unchanged (the scale rows of the covariance stay 0).
  bool estimate_scale = false;
  /// Prior sd of s_v and s_w around 1 (mice resolutions and radii are a
  /// few % off before calibration).
  Vec2 scale_sd{0.05, 0.05};
  /// Random walk of s_v and s_w, sd per sqrt(second): a floor that changes, a
  /// sensor that gets dirty. Over a step of dt the variance grows by
  /// scale_random_walk^2 dt.
  Vec2 scale_random_walk{1e-3, 1e-3};
  /// Process-noise floor added to every twist covariance: sd of vx, vy
  /// (m/s) and omega (rad/s) of a twist averaged over 10 ms; white, so over
  /// a step of dt its variance is floor^2 * (0.01 s / dt).
  Vec3 twist_noise_floor{0.05, 0.05, 0.1};
  /// Further twist noise in proportion to the twist itself (sd = relative *
  /// |v| or |omega| over 10 ms, white like the floor): resolution and
  /// mounting errors grow with speed.
  real twist_noise_relative = 0.05;
  /// After this many fixes in a row fail the gate the filter is taken to be
  /// lost, not the camera: the next fix is applied after the position and
  /// heading covariance are widened by its innovation.
  int max_consecutive_rejections = 5;
  /// False-alarm rate of a fix's test: its Mahalanobis distance against
  /// q(1 - alpha, M) (chi2.hpp), M = 2 for a position, 3 with heading;
  /// 0: no test, every fix is fused.
  real alpha = 0.001;
  /// nullopt when usable, else the first field out of its bounds, its path
  /// relative to this struct (options_check.hpp).
  OptionCheck validate() const;
};

enum class FixResult {
  kApplied,
  kRejected,  ///< gated out as an outlier
  kTooOld,    ///< older than the kept history
  kFuture,    ///< later than the newest prediction: predict first
  kInvalid,   ///< non-finite values or a covariance that is not positive
};
const char* describe(FixResult result);

class PoseEkf {
 public:
  /// Prediction steps kept for late fixes: 1.28 s at 100 Hz, 0.128 s at
  /// 1 kHz (26 KB; the Cortex-M4F program holds the whole pipeline in 128 KB).
  static constexpr std::size_t kHistory = 128;

  /// State (x, y, theta, s_v, s_w); without estimate_scale s = (1, 1) and
  /// its rows of the covariance are zero.
  static constexpr int kStates = 5;
  using StateCovariance = Mat<kStates, kStates>;

  /// `covariance`: of the pose; the scales start at 1 with sd
  /// options.scale_sd (when estimate_scale), uncorrelated with the pose.
  PoseEkf(double t0, const Pose2& initial, const Mat3& covariance, EkfOptions options = {});

  /// Predicts over (t - dt, t] with the twist and its covariance.
  void predict(double t, const Twist2& twist, const Mat3& twist_covariance, real dt);

  /// A position fix captured at t (world frame, m) with covariance r (m^2).
  FixResult update_position(double t, const Vec2& z, const Mat2& r);
  /// A position and heading fix (heading rad; r 3x3).
  FixResult update_pose(double t, const Vec3& z, const Mat3& r);

  const Pose2& pose() const { return pose_; }
  /// Covariance of (x, y, theta).
  Mat3 covariance() const { return cov_.topLeftCorner<3, 3>(); }
  /// (s_v, s_w): (1, 1) unless estimate_scale.
  const Vec2& scale() const { return scale_; }
  /// Covariance of (s_v, s_w); zero unless estimate_scale.
  Mat2 scale_covariance() const { return cov_.bottomRightCorner<2, 2>(); }
  /// Covariance of the whole state (x, y, theta, s_v, s_w).
  const StateCovariance& state_covariance() const { return cov_; }
  bool estimates_scale() const { return options_.estimate_scale; }
  double time() const { return t_; }
  /// Squared Mahalanobis distance of the last fix's innovation.
  real last_distance() const { return last_distance_; }

 private:
  struct Step {
    double t_begin, t_end;
    Twist2 twist;
    Mat3 q;             ///< twist covariance incl. the floor
    Pose2 pose_before;  ///< state at t_begin
    Vec2 scale_before;
    StateCovariance cov_before;
  };
  void propagate(const Twist2& twist, const Mat3& q, real dt);
  template <int M>
  FixResult update(double t, const Mat<M, 1>& z, const Mat<M, M>& r, real gate);
  template <int M>
  FixResult correct(const Mat<M, 1>& z, const Mat<M, M>& r, real gate);
  template <int N, int M>
  FixResult correct_states(const Mat<M, 1>& z, const Mat<M, M>& r, real gate);

  EkfOptions options_;
  real gate_position_, gate_pose_;  ///< q(1 - alpha, 2), q(1 - alpha, 3)
  double t_;
  Pose2 pose_;
  Vec2 scale_{1.0, 1.0};
  StateCovariance cov_ = StateCovariance::Zero();
  FixedRing<Step, kHistory> history_;
  real last_distance_ = 0.0;
  int consecutive_rejections_ = 0;
};

}  // namespace moa
