#include "moa/core/sekimori.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>

namespace moa {

OptionCheck SekimoriOptions::validate() const {
  InvalidOption bound;  // "-1 (automatic) or in [1, 16]"
  bound.append("-1 (automatic) or in [1, ");
  bound.append_integer(kMaxSensors);
  bound.append("]");
  return OptionsCheck()
      .positive("e_th", e_th)
      .require(r_th == -1 || (r_th >= 1 && r_th <= kMaxSensors), "r_th", bound.message(), r_th)
      .nested("wheels", wheels.validate())
      .nested("hold", hold.validate())
      .result();
}

std::variant<SekimoriEstimator, GeometryError> SekimoriEstimator::create(const SensorArray& array,
                                                                         SekimoriOptions options) {
  const auto check = LsEstimator::create(array, all_sensors(array.size()), 0.01);
  if (const auto* error = std::get_if<GeometryError>(&check)) return *error;
  // Every pair must itself determine a twist, or its residual is undefined.
  for (int i = 0; i < array.size(); ++i) {
    for (int j = i + 1; j < array.size(); ++j) {
      const SensorMask pair = (SensorMask{1} << i) | (SensorMask{1} << j);
      if (std::holds_alternative<GeometryError>(LsEstimator::create(array, pair, 0.01))) {
        return GeometryError::kRankDeficient;
      }
    }
  }
  return SekimoriEstimator(array, options);
}

SekimoriEstimator::SekimoriEstimator(const SensorArray& array, SekimoriOptions options)
    : n_(array.size()),
      options_(options),
      r_th_(options.r_th >= 0 ? options.r_th : std::max(1, array.size() - 2)),
      solver_(array) {
  for (int i = 0; i < n_; ++i) {
    const auto s = static_cast<std::size_t>(i);
    c_[s] = array[i].robot_velocity_from_counts();
    quant_[s] = c_[s] * c_[s].transpose() / 6.0;
  }
  for (int i = 0; i < n_; ++i) {
    for (int j = i + 1; j < n_; ++j) {
      Mat<4, 3> a;
      a.topRows<2>() = array[i].point_jacobian();
      a.bottomRows<2>() = array[j].point_jacobian();
      // The orthogonal complement of A's column space: the 4-D cross product
      // of its three columns, n_k = (-1)^k det(A without row k) (no
      // workspace, so nothing is allocated even at construction). A pair
      // whose A has rank < 3 (coincident sensors) gets n = 0: it always agrees.
      Vec4 n;
      for (int k = 0; k < 4; ++k) {
        Mat3 minor;
        for (int r = 0, row = 0; r < 4; ++r) {
          if (r != k) minor.row(row++) = a.row(r);
        }
        n(k) = (k % 2 == 0 ? 1.0 : -1.0) * minor.determinant();
      }
      const real norm = n.norm();
      normals_[static_cast<std::size_t>(pair_index(i, j))] =
          norm > std::numeric_limits<real>::min() ? Vec4(n / norm) : Vec4::Zero();
    }
  }
  for (int i = 0; i < n_; ++i) measurements_.info[static_cast<std::size_t>(i)].setIdentity();
  measurements_.size = n_;
}

real SekimoriEstimator::pair_residual(int i, int j) const {
  if (i > j) std::swap(i, j);
  return residual_[static_cast<std::size_t>(pair_index(i, j))];
}

std::optional<RobustEstimate> SekimoriEstimator::estimate(const ArraySample& sample,
                                                          const std::optional<Twist2>& wheels) {
  if (!(std::isfinite(sample.dt) && sample.dt > 0.0) || sample.size != n_) return std::nullopt;
  RobustEstimate out;
  for (int i = 0; i < n_; ++i) {
    const auto s = static_cast<std::size_t>(i);
    measurements_.u[s] = c_[s] * sample.counts[s] / sample.dt;
  }
  // Eq. (4) and (7): pair residuals on displacements, then votes.
  std::array<int, kMaxSensors> votes{};
  for (int i = 0; i < n_; ++i) {
    for (int j = i + 1; j < n_; ++j) {
      const auto p = static_cast<std::size_t>(pair_index(i, j));
      Vec4 a;
      a << measurements_.u[static_cast<std::size_t>(i)],
          measurements_.u[static_cast<std::size_t>(j)];
      const real e = normals_[p].dot(a * sample.dt);
      residual_[p] = e * e;
      if (residual_[p] <= options_.e_th) {
        ++votes[static_cast<std::size_t>(i)];
        ++votes[static_cast<std::size_t>(j)];
      }
    }
  }
  SensorMask reliable = 0;
  for (int i = 0; i < n_; ++i) {
    if (votes[static_cast<std::size_t>(i)] >= r_th_) reliable |= SensorMask{1} << i;
  }
  // Eqs. (8)-(9): unweighted least squares over the reliable sensors.
  const auto fit = solver_.fit(reliable, measurements_);
  if (fit) {
    // Report the covariance the quantisation gives for this unweighted fit:
    // Cov = N^-1 (sum A_i^T S_i A_i) N^-1 with N = sum A_i^T A_i.
    Mat3 middle = Mat3::Zero();
    for (int i = 0; i < n_; ++i) {
      if (!contains(reliable, i)) continue;
      const auto& a = solver_.jacobian(i);
      middle += a.transpose() * quant_[static_cast<std::size_t>(i)] * a / (sample.dt * sample.dt);
    }
    out.estimate.twist = fit->twist;
    out.estimate.covariance = fit->covariance * middle * fit->covariance;
    out.estimate.used = reliable;
    out.source = Source::kMice;
    for (int i = 0; i < n_; ++i) {
      if (!contains(reliable, i))
        out.excluded[static_cast<std::size_t>(i)] = Exclusion::kUnreliable;
    }
    fallback_.good(fit->twist, out.estimate.covariance, sample.t);
    return out;
  }
  for (int i = 0; i < n_; ++i) out.excluded[static_cast<std::size_t>(i)] = Exclusion::kFallback;
  fallback_.apply(out, wheels, options_.wheels, options_.hold, sample.t);
  return out;
}

}  // namespace moa
