#include "moa/core/ekf.hpp"

#include <Eigen/LU>
#include <cmath>
#include <limits>

#include "moa/core/chi2.hpp"
#include "moa/core/kalman.hpp"

namespace moa {

OptionCheck EkfOptions::validate() const {
  return OptionsCheck()
      .positive("scale_sd", scale_sd)
      .non_negative("scale_random_walk", scale_random_walk)
      .non_negative("twist_noise_floor", twist_noise_floor)
      .non_negative("twist_noise_relative", twist_noise_relative)
      .at_least("max_consecutive_rejections", max_consecutive_rejections, 1)
      .closed("alpha", alpha, 0.0, 0.5)
      .result();
}

const char* describe(FixResult result) {
  switch (result) {
    case FixResult::kApplied:
      return "applied";
    case FixResult::kRejected:
      return "rejected by the gate";
    case FixResult::kTooOld:
      return "older than the filter's history";
    case FixResult::kFuture:
      return "later than the newest prediction";
    case FixResult::kInvalid:
      return "not finite or not positive definite";
  }
  return "?";
}

Twist2 scaled_twist(const Twist2& twist, const Vec2& scale) {
  return Twist2{twist.v * scale(0), twist.omega * scale(1)};
}

Mat<3, 2> exact_step_scale_jacobian(const Pose2& pose, const Twist2& twist, const Vec2& scale,
                                    real dt) {
  const Mat3 g = exact_step_twist_jacobian(pose, scaled_twist(twist, scale), dt);
  Mat<3, 2> out;
  out.col(0) = g.leftCols<2>() * twist.v;
  out.col(1) = g.col(2) * twist.omega;
  return out;
}

namespace {
/// q(1 - alpha, dof); alpha = 0: no test (every fix is fused).
real fix_gate(real alpha, int dof) {
  return alpha > 0 ? static_cast<real>(chi2_quantile(1.0 - alpha, dof))
                   : std::numeric_limits<real>::infinity();
}
}  // namespace

PoseEkf::PoseEkf(double t0, const Pose2& initial, const Mat3& covariance, EkfOptions options)
    : options_(options),
      gate_position_(fix_gate(options.alpha, 2)),
      gate_pose_(fix_gate(options.alpha, 3)),
      t_(t0),
      pose_(initial) {
  cov_.topLeftCorner<3, 3>() = covariance;
  if (options_.estimate_scale) {
    cov_.bottomRightCorner<2, 2>() = options_.scale_sd.cwiseAbs2().asDiagonal();
  }
}

void PoseEkf::propagate(const Twist2& twist, const Mat3& q, real dt) {
  if (!options_.estimate_scale) {
    // The pose filter alone, on its 3x3 block: the same arithmetic as ever.
    const Mat3 f = exact_step_pose_jacobian(pose_, twist, dt);
    const Mat3 g = exact_step_twist_jacobian(pose_, twist, dt);
    pose_ = integrate_exact(pose_, twist, dt);
    const Mat3 p = cov_.topLeftCorner<3, 3>();
    cov_.topLeftCorner<3, 3>() = f * p * f.transpose() + g * q * g.transpose();
    return;
  }
  // Scale states: the twist integrated is S xi, S = diag(s_v, s_v, s_w);
  // its noise S Q S. The scales follow a random walk.
  const Twist2 used = scaled_twist(twist, scale_);
  const Mat3 g = exact_step_twist_jacobian(pose_, used, dt);
  StateCovariance f = StateCovariance::Identity();
  f.topLeftCorner<3, 3>() = exact_step_pose_jacobian(pose_, used, dt);
  f.block<3, 1>(0, 3) = g.leftCols<2>() * twist.v;
  f.block<3, 1>(0, 4) = g.col(2) * twist.omega;
  const Vec3 s(scale_(0), scale_(0), scale_(1));
  const Mat3 gs = g * s.asDiagonal();
  StateCovariance noise = StateCovariance::Zero();
  noise.topLeftCorner<3, 3>() = gs * q * gs.transpose();
  noise.bottomRightCorner<2, 2>() = (options_.scale_random_walk.cwiseAbs2() * dt).asDiagonal();
  pose_ = integrate_exact(pose_, used, dt);
  cov_ = f * cov_ * f.transpose() + noise;
}

void PoseEkf::predict(double t, const Twist2& twist, const Mat3& twist_covariance, real dt) {
  constexpr real kFloorInterval = 0.01;  // s, see EkfOptions::twist_noise_floor
  const Vec3 relative =
      options_.twist_noise_relative * Vec3(twist.v.norm(), twist.v.norm(), std::abs(twist.omega));
  const Vec3 floor =
      (options_.twist_noise_floor.cwiseAbs2() + relative.cwiseAbs2()) * (kFloorInterval / dt);
  Step step{t - dt, t, twist, twist_covariance + Mat3(floor.asDiagonal()), pose_, scale_, cov_};
  if (history_.full()) history_.pop_front();
  history_.push_back(step);
  propagate(step.twist, step.q, dt);
  t_ = t;
}

template <int M>
FixResult PoseEkf::correct(const Mat<M, 1>& z, const Mat<M, M>& r, real gate) {
  return options_.estimate_scale ? correct_states<kStates, M>(z, r, gate)
                                 : correct_states<3, M>(z, r, gate);
}

// N: the states updated, the pose (3) or the pose and the scales (5).
template <int N, int M>
FixResult PoseEkf::correct_states(const Mat<M, 1>& z, const Mat<M, M>& r, real gate) {
  using HMatrix = Mat<M, N>;
  const HMatrix h = HMatrix::Identity();
  Mat<N, N> cov = cov_.topLeftCorner<N, N>();
  // 1. innovation, heading wrapped
  Mat<M, 1> y = z - h.template leftCols<3>() * Vec3(pose_.t.x(), pose_.t.y(), pose_.theta);
  if constexpr (M == 3) y(2) = wrap_angle(y(2));
  // 2. its Mahalanobis distance y^T S^-1 y, S = H P H^T + R (kalman.hpp)
  last_distance_ = test_ratio<M>(y, h * cov * h.transpose() + r, real(1));
  // 3. gate (with recovery after too many rejections in a row)
  if (!(last_distance_ <= gate)) {
    if (++consecutive_rejections_ <= options_.max_consecutive_rejections) {
      return FixResult::kRejected;
    }
    for (int i = 0; i < M; ++i) cov(i, i) += y(i) * y(i);
    if constexpr (M == 2) cov(2, 2) += 0.01;  // heading unknown to this fix: 0.1 rad more
  }
  consecutive_rejections_ = 0;
  // 4. the core's Kalman update (kalman.hpp, Joseph form) of the correction
  Mat<N, 1> dx = Mat<N, 1>::Zero();
  joseph_update<N, M>(dx, cov, y, h, r);
  pose_.t += dx.template head<2>();
  pose_.theta += dx(2);
  if constexpr (N == kStates) scale_ += dx.template tail<2>();
  cov_.topLeftCorner<N, N>() = cov;
  return FixResult::kApplied;
}

template <int M>
FixResult PoseEkf::update(double t, const Mat<M, 1>& z, const Mat<M, M>& r, real gate) {
  constexpr double kSameTime = 1e-9;  // s: a fix this close to a step boundary is on it
  if (!std::isfinite(t) || !z.allFinite() || !r.allFinite() || !(r.determinant() > 0.0)) {
    return FixResult::kInvalid;
  }
  if (t > t_ + kSameTime) return FixResult::kFuture;
  if (t >= t_ - kSameTime || history_.empty()) {
    if (history_.empty() && t < t_ - kSameTime) return FixResult::kTooOld;
    return correct<M>(z, r, gate);
  }
  // Late fix: find the step (t_begin, t_end] that contains t.
  std::size_t k = history_.size();
  while (k > 0 && !(history_[k - 1].t_begin < t - kSameTime)) --k;
  if (k == 0) return FixResult::kTooOld;
  const std::size_t index = k - 1;
  const Pose2 saved_pose = pose_;
  const Vec2 saved_scale = scale_;
  const StateCovariance saved_cov = cov_;
  Step& step = history_[index];
  pose_ = step.pose_before;
  scale_ = step.scale_before;
  cov_ = step.cov_before;
  const double dt = step.t_end - step.t_begin;
  const double dt1 = t - step.t_begin;
  const bool split = step.t_end - t > kSameTime;
  // A twist averaged over part of the step is noisier by dt / dt_part (white
  // noise), which keeps the pose covariance of the whole step unchanged.
  propagate(step.twist, split ? Mat3(step.q * static_cast<real>(dt / dt1)) : step.q,
            static_cast<real>(dt1));
  const FixResult result = correct<M>(z, r, gate);
  if (result != FixResult::kApplied) {
    pose_ = saved_pose;
    scale_ = saved_scale;
    cov_ = saved_cov;
    return result;
  }
  std::size_t next = index + 1;
  if (split) {
    // Replace the step by its two parts; the second starts from the fixed state.
    Step second{t,     step.t_end, step.twist, step.q * static_cast<real>(dt / (step.t_end - t)),
                pose_, scale_,     cov_};
    step.t_end = t;
    step.q *= static_cast<real>(dt / dt1);
    if (history_.full()) {  // make room by dropping the oldest step
      history_.pop_front();
      --next;
    }
    history_.insert(next, second);
    propagate(second.twist, second.q, static_cast<real>(second.t_end - second.t_begin));
    ++next;
  }
  // Re-predict the later steps from the corrected state.
  for (std::size_t j = next; j < history_.size(); ++j) {
    Step& later = history_[j];
    later.pose_before = pose_;
    later.scale_before = scale_;
    later.cov_before = cov_;
    propagate(later.twist, later.q, static_cast<real>(later.t_end - later.t_begin));
  }
  return FixResult::kApplied;
}

FixResult PoseEkf::update_position(double t, const Vec2& z, const Mat2& r) {
  return update<2>(t, z, r, gate_position_);
}

FixResult PoseEkf::update_pose(double t, const Vec3& z, const Mat3& r) {
  return update<3>(t, z, r, gate_pose_);
}

}  // namespace moa
