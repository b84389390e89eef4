#include "moa/calibration/kimlee.hpp"

#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "moa/core/estimate.hpp"

namespace moa {

KimLeeMeasurement kimlee_measurement(const SensorArray& nominal, const Twist2& v_m,
                                     std::span<const Eigen::Vector2d> v_s) {
  const int n = nominal.size();
  const double vx = v_m.v.x();
  const double vy = v_m.v.y();
  const double w = v_m.omega;
  KimLeeMeasurement m;
  m.s.setZero(3, 2 * n);
  m.b.setZero();
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d& p = nominal[i].position;
    const Eigen::Vector2d& u = v_s[static_cast<std::size_t>(i)];
    // C_1 (eq. (38)): only the third row.
    m.s(2, 2 * i) += u.y();
    m.s(2, 2 * i + 1) += -u.x();
    // C_2 (eqs. (39)-(40)).
    m.s(0, 2 * i + 1) += w;
    m.s(1, 2 * i) += -w;
    m.s(2, 2 * i) += -vy - 2.0 * w * p.x();
    m.s(2, 2 * i + 1) += vx - 2.0 * w * p.y();
    // b_k = A_bar^T (A_bar v_m - v_s) (eq. (43)), two rows of A_bar per sensor.
    const Eigen::Matrix<double, 2, 3> a = nominal[i].point_jacobian();
    m.b += a.transpose() * (a * v_m.vector() - u);
  }
  return m;
}

KimLeeSystem kimlee_system(const SensorArray& nominal, std::span<const CalibrationSample> samples) {
  const int n = nominal.size();
  const auto rows = static_cast<Eigen::Index>(samples.size() + 2);
  KimLeeSystem sys;
  sys.s.setZero(rows, 2 * n);
  sys.b.setZero(rows);
  for (std::size_t k = 0; k < samples.size(); ++k) {
    const auto u = point_velocities(nominal, samples[k].mice);
    const KimLeeMeasurement m =
        kimlee_measurement(nominal, samples[k].reference, std::span(u.data(), u.size()));
    if (k == 0) {
      sys.s.topRows<3>() = m.s;
      sys.b.head<3>() = m.b;
    } else {
      const auto r = static_cast<Eigen::Index>(k + 2);
      sys.s.row(r) = m.s.row(2);
      sys.b(r) = m.b(2);
    }
  }
  return sys;
}

namespace {

// Upper bounds of the noise of one measured velocity component (m/s); see
// the header for why the minimum of the two data estimates is taken.
double estimate_velocity_noise(const SensorArray& nominal,
                               std::span<const CalibrationSample> samples) {
  const int n = nominal.size();
  std::vector<std::array<Eigen::Vector2d, kMaxSensors>> u;
  u.reserve(samples.size());
  for (const auto& s : samples) u.push_back(point_velocities(nominal, s.mice));

  // Quantisation floor at the median interval.
  std::vector<double> dts;
  for (const auto& s : samples) dts.push_back(s.mice.dt);
  std::nth_element(dts.begin(), dts.begin() + static_cast<std::ptrdiff_t>(dts.size() / 2),
                   dts.end());
  const double dt = dts[dts.size() / 2];
  double quant2 = 0.0;
  for (int i = 0; i < n; ++i) {
    const Eigen::Matrix2d c = nominal[i].robot_velocity_from_counts();
    quant2 += (c * c.transpose()).trace() / 2.0 / 6.0 / (dt * dt);
  }
  quant2 /= n;

  double succ = std::numeric_limits<double>::infinity();
  if (u.size() >= 2) {
    double sum = 0.0;
    for (std::size_t k = 1; k < u.size(); ++k) {
      for (int i = 0; i < n; ++i) {
        const auto j = static_cast<std::size_t>(i);
        sum += (u[k][j] - u[k - 1][j]).squaredNorm();
      }
    }
    succ = sum / (2.0 * static_cast<double>((u.size() - 1) * 2 * static_cast<std::size_t>(n)));
  }

  double resid = std::numeric_limits<double>::infinity();
  if (2 * n > 3) {
    Eigen::MatrixXd a(2 * n, 3);
    for (int i = 0; i < n; ++i) a.middleRows<2>(2 * i) = nominal[i].point_jacobian();
    const Eigen::MatrixXd pinv = a.completeOrthogonalDecomposition().pseudoInverse();
    double sum = 0.0;
    for (const auto& uk : u) {
      Eigen::VectorXd v(2 * n);
      for (int i = 0; i < n; ++i) v.segment<2>(2 * i) = uk[static_cast<std::size_t>(i)];
      sum += (v - a * (pinv * v)).squaredNorm();
    }
    resid = sum / (static_cast<double>(u.size()) * (2.0 * n - 3.0));
  }
  return std::sqrt(std::max(quant2, std::min(succ, resid)));
}

}  // namespace

std::variant<KimLeeCalibration, CalibrationError> calibrate_kimlee(
    const SensorArray& nominal, std::span<const CalibrationSample> samples,
    const KimLeeOptions& options) {
  if (const auto error = check_nominal(nominal)) return *error;
  const int n = nominal.size();
  std::vector<CalibrationSample> used;
  for (const auto& s : samples) {
    if (s.mice.size != n) return CalibrationError::kTooManySensors;
    if (usable_sample(s, n)) used.push_back(s);
  }
  if (used.empty()) return CalibrationError::kTooFewSamples;
  bool moved = false;
  for (const auto& s : used) moved = moved || s.reference.vector().squaredNorm() > 0.0;
  if (!moved) return CalibrationError::kNoMotion;

  const KimLeeSystem sys = kimlee_system(nominal, used);
  KimLeeCalibration cal;
  cal.measurements = static_cast<int>(used.size());
  cal.velocity_noise =
      options.velocity_noise ? *options.velocity_noise : estimate_velocity_noise(nominal, used);

  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(sys.s, Eigen::ComputeThinU | Eigen::ComputeThinV);
  cal.singular_values = svd.singularValues();
  const double rows = static_cast<double>(sys.s.rows());
  const double cols = static_cast<double>(sys.s.cols());
  const double s_max = cal.singular_values.size() > 0 ? cal.singular_values(0) : 0.0;
  cal.threshold =
      std::max(options.threshold_factor * cal.velocity_noise * (std::sqrt(rows) + std::sqrt(cols)),
               cols * rows * std::numeric_limits<double>::epsilon() * s_max);
  cal.rank = 0;
  while (cal.rank < cal.singular_values.size() && cal.singular_values(cal.rank) > cal.threshold) {
    ++cal.rank;
  }

  // Minimum-norm solution over the kept singular directions.
  const Eigen::MatrixXd u_r = svd.matrixU().leftCols(cal.rank);
  const Eigen::MatrixXd v_r = svd.matrixV().leftCols(cal.rank);
  const Eigen::VectorXd inv_s = cal.singular_values.head(cal.rank).cwiseInverse();
  cal.delta_p = v_r * inv_s.asDiagonal() * (u_r.transpose() * sys.b);
  const double dof = rows - cal.rank;
  const double sigma2 = dof > 0.0 ? (sys.b - sys.s * cal.delta_p).squaredNorm() / dof : 0.0;
  cal.covariance = sigma2 * v_r * inv_s.cwiseAbs2().asDiagonal() * v_r.transpose();

  cal.calibrated = nominal;
  for (int i = 0; i < n; ++i) cal.calibrated[i].position += cal.delta_p.segment<2>(2 * i);

  cal.residual_rms.assign(static_cast<std::size_t>(n), 0.0);
  for (const auto& s : used) {
    const auto u = point_velocities(nominal, s.mice);
    for (int i = 0; i < n; ++i) {
      const auto j = static_cast<std::size_t>(i);
      cal.residual_rms[j] +=
          (u[j] - cal.calibrated[i].point_jacobian() * s.reference.vector()).squaredNorm();
    }
  }
  for (auto& r : cal.residual_rms) r = std::sqrt(r / static_cast<double>(used.size()));
  return cal;
}

}  // namespace moa
