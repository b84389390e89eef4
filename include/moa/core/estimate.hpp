// Robot twist from one synchronised sample of the sensor array.
//
// Each sensor i gives the velocity of its point in the robot frame,
//   u_i = G_i^-1 counts_i / dt = A_i x + e_i,  x = (vx, vy, omega),
// with A_i = [I | J p_i] (Kim & Lee eq. (6)). Stacking the used sensors,
// the weighted least-squares estimate and its covariance are
//   x = B u,   B = (A^T W A)^-1 A^T W,   Cov(x) = B Sigma B^T,
// (Kim & Lee eqs. (7)-(8) with weights). B depends only on the geometry and
// the set of sensors, so it is computed once; a sample costs O(N).
//
// Noise model per sensor (robot frame, m^2/s^2):
//   Sigma_i(dt) = noise_i^2 I + C_i C_i^T / (6 dt^2),  C_i = G_i^-1 (m per count)
// The second term is count quantisation: a count total over an interval is
// the difference of two roundings, each uniform with variance 1/12 count^2.
// Weights W_i = 1 / (noise_i^2 + q_i / dt_ref^2), q_i = tr(C_i C_i^T) / 12,
// with dt_ref the nominal sample interval; a sensor with no configured noise
// counts as noise 0, so only quantisation weighs it.
#pragma once

#include <Eigen/Core>
#include <array>
#include <optional>
#include <span>
#include <variant>

#include "moa/core/array.hpp"
#include "moa/core/se2.hpp"

namespace moa {

/// Why a sensor geometry cannot give a twist.
enum class GeometryError {
  kTooFewSensors,   ///< fewer than two sensors selected
  kTooManySensors,  ///< more than kMaxSensors, or a mask bit past the array
  kRankDeficient,   ///< A^T A singular: the sensors do not observe rotation
  kInvalidMount,    ///< cpi, scale or noise not positive and finite; a refused speed scale
  /// the sensors' latencies spread wider than the synchroniser's pending
  /// epochs hold (SynchroniserOptions::validate)
  kLatencySpread,
};
const char* describe(GeometryError error);

/// cpi and scale positive and finite, position and yaw finite, noise (when
/// given) finite and not negative, the speed scale (when given) not refused.
bool valid_mount(const SensorMount& m);

/// A twist estimate with its covariance.
struct TwistEstimate {
  Twist2 twist;
  Mat3 covariance = Mat3::Zero();  ///< (vx, vy, omega), SI
  SensorMask used = 0;
};

/// The sensor points' robot-frame velocities u_i = G_i^-1 counts_i / dt (m/s).
std::array<Vec2, kMaxSensors> point_velocities(const SensorArray& array, const ArraySample& sample);

/// Weighted least squares over a fixed set of sensors, gain precomputed.
class LsEstimator {
 public:
  /// Smallest accepted lambda_min / lambda_max of A^T A (omega column in m):
  /// sensors spread over less than ~10 um are refused as coincident.
  static constexpr real kMinConditionReciprocal = 1e-10;

  /// Builds the estimator for the sensors in `used`, or says why not.
  /// `reference_dt` (s) is the nominal sample interval used for the weights.
  static std::variant<LsEstimator, GeometryError> create(const SensorArray& array, SensorMask used,
                                                         real reference_dt);

  /// The estimate for one sample, nullopt if dt is not positive and finite.
  std::optional<TwistEstimate> estimate(const ArraySample& sample) const;

  /// The 3 x 2N gain B from stacked point velocities u to the twist.
  const Eigen::Matrix<real, 3, Eigen::Dynamic, 0, 3, 2 * kMaxSensors>& gain() const {
    return gain_;
  }
  SensorMask used() const { return used_; }

 private:
  LsEstimator() = default;

  SensorMask used_ = 0;
  int size_ = 0;
  /// B (3 x 2N): twist from stacked point velocities; unused columns zero.
  Eigen::Matrix<real, 3, Eigen::Dynamic, 0, 3, 2 * kMaxSensors> gain_;
  /// B blockdiag(C_i): twist * dt from stacked counts.
  Eigen::Matrix<real, 3, Eigen::Dynamic, 0, 3, 2 * kMaxSensors> counts_gain_;
  Mat3 noise_cov_ = Mat3::Zero();         ///< sum B_i noise_i^2 B_i^T
  Mat3 quantisation_cov_ = Mat3::Zero();  ///< times 1/dt^2
};

/// Kim & Lee eqs. (9)-(10): for mice at the vertices of a regular polygon
/// (radius r, first vertex at theta, see regular_polygon()) the least-squares
/// twist is the plain average
///   vx = mean u_ix,  vy = mean u_iy,
///   omega = mean (-sin(a_i) u_ix + cos(a_i) u_iy) / r,  a_i = theta + i 2 pi/N.
/// `u` holds the N point velocities (m/s, robot frame).
Twist2 average_regular_polygon(std::span<const Vec2> u, real r, real theta);

}  // namespace moa
