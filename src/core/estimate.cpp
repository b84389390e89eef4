#include "moa/core/estimate.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <cmath>
#include <numbers>

namespace moa {

const char* describe(GeometryError error) {
  switch (error) {
    case GeometryError::kTooFewSensors:
      return "fewer than two sensors: a twist needs at least two, or one with a gyro (the "
             "consensus estimator and imu.csv in the log)";
    case GeometryError::kTooManySensors:
      return "more sensors than moa::kMaxSensors, or a sensor index past the array";
    case GeometryError::kRankDeficient:
      return "rank-deficient geometry: the sensors sit at one point, so rotation is not observable";
    case GeometryError::kInvalidMount:
      return "a sensor has cpi, scale or noise that is not positive and finite, or a speed_scale "
             "table that is refused";
    case GeometryError::kLatencySpread:
      return "the sensors' latencies spread too wide: max_row_interval plus the largest latency "
             "minus the smallest (0 included) must be at most 61 epochs";
  }
  return "unknown geometry error";
}

std::array<Vec2, kMaxSensors> point_velocities(const SensorArray& array,
                                               const ArraySample& sample) {
  std::array<Vec2, kMaxSensors> u = zeros<Vec2>();
  for (int i = 0; i < sample.size && i < array.size(); ++i) {
    u[static_cast<std::size_t>(i)] = array[i].robot_velocity_from_counts() *
                                     sample.counts[static_cast<std::size_t>(i)] / sample.dt;
  }
  return u;
}

bool valid_mount(const SensorMount& m) {
  const auto positive = [](real x) { return std::isfinite(x) && x > 0.0; };
  return positive(m.cpi) && positive(m.scale.x()) && positive(m.scale.y()) &&
         m.position.allFinite() && std::isfinite(m.yaw) &&
         (!m.noise || (std::isfinite(*m.noise) && *m.noise >= 0.0)) && !m.speed_scale.error();
}

std::variant<LsEstimator, GeometryError> LsEstimator::create(const SensorArray& array,
                                                             SensorMask used, real reference_dt) {
  const int n = array.size();
  if (n > kMaxSensors || (n < 32 && (used >> n) != 0)) return GeometryError::kTooManySensors;
  if (count_sensors(used) < 2) return GeometryError::kTooFewSensors;
  for (int i = 0; i < n; ++i) {
    if (contains(used, i) && !valid_mount(array[i])) return GeometryError::kInvalidMount;
  }

  // Normal matrices: unweighted for the rank test, weighted for the gain.
  Mat3 ata = Mat3::Zero();
  Mat3 atwa = Mat3::Zero();
  std::array<real, kMaxSensors> weight{};
  std::array<Mat2, kMaxSensors> quant = zeros<Mat2>();  // C_i C_i^T / 6, m^2 per count^2
  for (int i = 0; i < n; ++i) {
    if (!contains(used, i)) continue;
    const auto k = static_cast<std::size_t>(i);
    const Mat2 c = array[i].robot_velocity_from_counts();
    quant[k] = c * c.transpose() / 6.0;
    const real noise2 = array[i].noise ? *array[i].noise * *array[i].noise : 0.0;
    weight[k] = 1.0 / (noise2 + quant[k].trace() / 2.0 / (reference_dt * reference_dt));
    const Mat<2, 3> a = array[i].point_jacobian();
    ata += a.transpose() * a;
    atwa += weight[k] * a.transpose() * a;
  }
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(ata, Eigen::EigenvaluesOnly);
  if (!(eig.eigenvalues()(0) > kMinConditionReciprocal * eig.eigenvalues()(2))) {
    return GeometryError::kRankDeficient;
  }

  LsEstimator est;
  est.used_ = used;
  est.size_ = n;
  est.gain_.setZero(3, 2 * n);
  est.counts_gain_.setZero(3, 2 * n);
  const Mat3 inv = atwa.inverse();
  for (int i = 0; i < n; ++i) {
    if (!contains(used, i)) continue;
    const auto k = static_cast<std::size_t>(i);
    const Mat<3, 2> b = weight[k] * inv * array[i].point_jacobian().transpose();
    est.gain_.middleCols<2>(2 * i) = b;
    est.counts_gain_.middleCols<2>(2 * i) = b * array[i].robot_velocity_from_counts();
    const real noise2 = array[i].noise ? *array[i].noise * *array[i].noise : 0.0;
    est.noise_cov_ += noise2 * b * b.transpose();
    est.quantisation_cov_ += b * quant[k] * b.transpose();
  }
  return est;
}

std::optional<TwistEstimate> LsEstimator::estimate(const ArraySample& sample) const {
  if (!(std::isfinite(sample.dt) && sample.dt > 0.0) || sample.size != size_) return std::nullopt;
  Vec3 x = Vec3::Zero();
  for (int i = 0; i < size_; ++i) {
    if (contains(used_, i)) {
      x += counts_gain_.middleCols<2>(2 * i) * sample.counts[static_cast<std::size_t>(i)];
    }
  }
  TwistEstimate out;
  out.twist = Twist2::from_vector(x / sample.dt);
  out.covariance = noise_cov_ + quantisation_cov_ / (sample.dt * sample.dt);
  out.used = used_;
  return out;
}

Twist2 average_regular_polygon(std::span<const Vec2> u, real r, real theta) {
  const auto n = static_cast<real>(u.size());
  Twist2 out;
  for (std::size_t i = 0; i < u.size(); ++i) {
    const real a =
        theta + static_cast<real>(i) * 2.0 * std::numbers::pi_v<real> / static_cast<real>(n);
    out.v += u[i] / n;
    out.omega += (-std::sin(a) * u[i].x() + std::cos(a) * u[i].y()) / (r * n);
  }
  return out;
}

}  // namespace moa
