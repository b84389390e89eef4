#include "moa/calibration/gyro_calibration.hpp"

#include "moa/calibration/lag_search.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <optional>

namespace moa {

const char* describe(GyroCalibrationError error) {
  switch (error) {
    case GyroCalibrationError::kTooFewRows:
      return "fewer than 20 reference intervals within the time span of the gyro's rows";
    case GyroCalibrationError::kBadInput:
      return "times that do not increase or values that are not finite";
    case GyroCalibrationError::kNoRotation:
      return "the reference does not turn (its rate hardly varies): the gyro's scale cannot be "
             "told from its bias; calibrate on a log with turns";
    case GyroCalibrationError::kNoCorrelation:
      return "the gyro's rate does not correlate with the reference's at any latency within the "
             "search range: not the same motion (another run, another clock) or a gyro that "
             "reads the rotation with the opposite sign";
  }
  return "gyro calibration error";
}

namespace {

using Vec5 = Eigen::Matrix<double, 5, 1>;
using Mat5 = Eigen::Matrix<double, 5, 5>;

// The integral of a rate series (rad) and of its velocity (m, robot frame,
// summed), piecewise linear between its times; its rate piecewise constant.
class Integral {
 public:
  Integral(const std::vector<double>& t, const std::vector<double>& rate,
           const std::vector<Eigen::Vector2d>& velocity)
      : t_(t),
        rate_(rate),
        velocity_(velocity),
        angle_(t.size(), 0.0),
        displacement_(velocity.empty() ? 0 : t.size(), Eigen::Vector2d::Zero()) {
    for (std::size_t k = 0; k < rate_.size(); ++k) {
      angle_[k + 1] = angle_[k] + rate_[k] * (t_[k + 1] - t_[k]);
      if (has_velocity()) {
        displacement_[k + 1] = displacement_[k] + velocity_[k] * (t_[k + 1] - t_[k]);
      }
    }
  }
  bool has_velocity() const { return !velocity_.empty(); }
  double front() const { return t_.front(); }
  double back() const { return t_.back(); }
  // Interval k with t_[k] <= t <= t_[k + 1] (t within the span).
  std::size_t interval(double t) const {
    const auto it = std::upper_bound(t_.begin(), t_.end(), t);
    const auto k = static_cast<std::size_t>(std::max<std::ptrdiff_t>(it - t_.begin(), 1)) - 1;
    return std::min(k, rate_.size() - 1);
  }
  double angle(double t) const {
    const std::size_t k = interval(t);
    return angle_[k] + rate_[k] * (t - t_[k]);
  }
  double rate(double t) const { return rate_[interval(t)]; }
  Eigen::Vector2d displacement(double t) const {
    const std::size_t k = interval(t);
    return displacement_[k] + velocity_[k] * (t - t_[k]);
  }

 private:
  const std::vector<double>& t_;
  const std::vector<double>& rate_;
  const std::vector<Eigen::Vector2d>& velocity_;
  std::vector<double> angle_;
  std::vector<Eigen::Vector2d> displacement_;
};

// One reference interval (t0, t1]: its rate w (rad/s) and its velocity
// averaged over the interval widened by kVelocityHalfWindow each side (m/s;
// widened so that its noise is not w's: the array's velocity and rotation
// come from the same counts).
struct Row {
  double t0 = 0.0, t1 = 0.0;
  double w = 0.0;
  Eigen::Vector2d v = Eigen::Vector2d::Zero();
};
constexpr double kVelocityHalfWindow = 0.25;  // s

// G(L): the gyro's rate averaged over the reference interval as the gyro's
// clock stamps it, (t0 + L, t1 + L], and dG/dL.
double gyro_rate(const Integral& gyro, const Row& r, double latency) {
  return (gyro.angle(r.t1 + latency) - gyro.angle(r.t0 + latency)) / (r.t1 - r.t0);
}
double gyro_rate_slope(const Integral& gyro, const Row& r, double latency) {
  return (gyro.rate(r.t1 + latency) - gyro.rate(r.t0 + latency)) / (r.t1 - r.t0);
}

// The residual r = w - (alpha G(L) + beta + gamma . v), x = (alpha, beta, L,
// gamma_x, gamma_y); `gradient`: dr/dx.
double residual_of(const Integral& gyro, const Row& r, const Vec5& x, Vec5* gradient) {
  const double g = gyro_rate(gyro, r, x(2));
  if (gradient != nullptr) {
    *gradient << -g, -1.0, -x(0) * gyro_rate_slope(gyro, r, x(2)), -r.v.x(), -r.v.y();
  }
  return r.w - x(0) * g - x(1) - x.tail<2>().dot(r.v);
}

double correlation(const std::vector<Row>& rows, const Integral& gyro, double latency) {
  std::vector<double> x, y;
  x.reserve(rows.size());
  y.reserve(rows.size());
  for (const Row& r : rows) {
    x.push_back(gyro_rate(gyro, r, latency));
    y.push_back(r.w);
  }
  return pearson_correlation(x, y);
}

double median(std::vector<double> v) {
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

struct Fit {
  Vec5 x = Vec5::Zero();
  double ssr = 0.0;
};

double ssr_at(const std::vector<Row>& rows, const std::vector<bool>& in, const Integral& gyro,
              const Vec5& x) {
  double s = 0.0;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    if (!in[i]) continue;
    const double r = residual_of(gyro, rows[i], x, nullptr);
    s += r * r;
  }
  return s;
}

// The Gauss-Newton normal equations of the rows in `in` at x (n d = v);
// without a velocity the couplings' diagonal is 1 (their step 0).
void normal_equations(const std::vector<Row>& rows, const std::vector<bool>& in,
                      const Integral& gyro, bool coupled, const Vec5& x, Mat5& n, Vec5& v) {
  n.setZero();
  v.setZero();
  Vec5 j;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    if (!in[i]) continue;
    const double r = residual_of(gyro, rows[i], x, &j);
    n += j * j.transpose();
    v -= j * r;
  }
  if (!coupled) n(3, 3) = n(4, 4) = 1.0;
}

// (alpha, beta, gamma) linear at latency L (one step with L fixed), then
// Gauss-Newton on all five with the step in L at most `step`, halved until
// the sum of squares drops.
std::optional<Fit> fit(const std::vector<Row>& rows, const std::vector<bool>& in,
                       const Integral& gyro, bool coupled, double latency, double max_latency,
                       double step) {
  Fit f;
  f.x(2) = latency;
  Mat5 n;
  Vec5 v;
  normal_equations(rows, in, gyro, coupled, f.x, n, v);
  n.row(2).setZero();
  n.col(2).setZero();
  n(2, 2) = 1.0;
  v(2) = 0.0;
  const Vec5 first = n.ldlt().solve(v);
  if (!first.allFinite()) return std::nullopt;
  f.x += first;
  f.ssr = ssr_at(rows, in, gyro, f.x);
  for (int iteration = 0; iteration < 30; ++iteration) {
    normal_equations(rows, in, gyro, coupled, f.x, n, v);
    Vec5 d = n.ldlt().solve(v);
    if (!d.allFinite()) break;
    if (std::abs(d(2)) > step) d *= step / std::abs(d(2));
    bool improved = false;
    for (int halving = 0; halving < 8 && !improved; ++halving, d *= 0.5) {
      Vec5 x = f.x + d;
      x(2) = std::clamp(x(2), -max_latency, max_latency);
      const double s = ssr_at(rows, in, gyro, x);
      if (s < f.ssr) {
        f.x = x;
        f.ssr = s;
        improved = true;
      }
    }
    if (!improved || std::abs(d(2)) < 1e-9) break;
  }
  return f;
}

}  // namespace

std::variant<GyroCalibration, GyroCalibrationError> calibrate_gyro(
    std::span<const double> t, std::span<const double> g, const RateSeries& reference,
    const GyroCalibrationOptions& options) {
  const bool coupled = !reference.velocity.empty();
  if (t.size() != g.size() || t.size() < 2 || reference.t.size() != reference.rate.size() + 1 ||
      reference.rate.empty() || (coupled && reference.velocity.size() != reference.rate.size())) {
    return t.size() < 2 ? GyroCalibrationError::kTooFewRows : GyroCalibrationError::kBadInput;
  }
  for (std::size_t k = 0; k < reference.rate.size(); ++k) {
    if (!(reference.t[k + 1] > reference.t[k]) || !std::isfinite(reference.rate[k]) ||
        !std::isfinite(reference.t[k + 1]) || !std::isfinite(reference.t[k]) ||
        (coupled && !reference.velocity[k].allFinite())) {
      return GyroCalibrationError::kBadInput;
    }
  }
  // The gyro as a rate series: row i averages (t[i - 1], t[i]].
  const std::vector<double> gyro_t(t.begin(), t.end());
  const std::vector<double> gyro_rate_of(g.begin() + 1, g.end());
  const std::vector<Eigen::Vector2d> none;
  std::vector<double> dts;
  for (std::size_t i = 1; i < t.size(); ++i) {
    if (!std::isfinite(t[i]) || !std::isfinite(g[i]) || !std::isfinite(t[i - 1]) ||
        !(t[i] > t[i - 1])) {
      return GyroCalibrationError::kBadInput;
    }
    dts.push_back(t[i] - t[i - 1]);
  }
  const Integral gyro(gyro_t, gyro_rate_of, none);
  const Integral ref(reference.t, reference.rate, reference.velocity);
  const double max_latency = options.max_latency;

  // Reference intervals whose gyro interval, shifted by any L within
  // +-max_latency, lies within the gyro's rows, and whose widened velocity
  // window lies within the reference.
  std::vector<Row> rows;
  for (std::size_t k = 0; k < reference.rate.size(); ++k) {
    Row r{reference.t[k], reference.t[k + 1], reference.rate[k], Eigen::Vector2d::Zero()};
    if (r.t0 - max_latency < gyro.front() || r.t1 + max_latency > gyro.back()) continue;
    if (coupled) {
      const double a = r.t0 - kVelocityHalfWindow, b = r.t1 + kVelocityHalfWindow;
      if (a < ref.front() || b > ref.back()) continue;
      r.v = (ref.displacement(b) - ref.displacement(a)) / (b - a);
    }
    rows.push_back(r);
  }
  if (rows.size() < 20) return GyroCalibrationError::kTooFewRows;

  GyroCalibration out;
  out.rows = rows.size();
  {
    double s = 0.0, ss = 0.0, dt = 0.0;
    for (const Row& r : rows) {
      const double d = r.t1 - r.t0;
      s += r.w * d;
      ss += r.w * r.w * d;
      dt += d;
    }
    out.reference_sd = std::sqrt(std::max(ss / dt - (s / dt) * (s / dt), 0.0));
    if (!(out.reference_sd >= options.min_rotation)) return GyroCalibrationError::kNoRotation;
  }

  // 1. Coarse latency: the correlation's peak on a grid of the gyro's row interval.
  const double step = std::max(median(dts), 1e-4);
  const int lags = static_cast<int>(std::floor(max_latency / step));
  if (lags < 2) return GyroCalibrationError::kNoCorrelation;
  std::vector<double> c(static_cast<std::size_t>(2 * lags + 1));
  for (int j = -lags; j <= lags; ++j) {
    c[static_cast<std::size_t>(j + lags)] = correlation(rows, gyro, j * step);
  }
  const auto peak = correlation_peak(c, step, options.min_correlation);
  out.correlation = *std::max_element(c.begin(), c.end());
  if (!peak) return GyroCalibrationError::kNoCorrelation;
  out.coarse_latency = peak->lag;

  // 2. The fit, rows beyond outlier_sigmas robust sigmas dropped.
  std::vector<bool> in(rows.size(), true);
  std::optional<Fit> f;
  std::vector<double> residual(rows.size()), deviation(rows.size());
  for (int pass = 0; pass < 5; ++pass) {
    f = fit(rows, in, gyro, coupled, f ? f->x(2) : out.coarse_latency, max_latency, step);
    if (!f) return GyroCalibrationError::kNoRotation;
    for (std::size_t i = 0; i < rows.size(); ++i) {
      residual[i] = residual_of(gyro, rows[i], f->x, nullptr);
    }
    const double m = median(residual);
    for (std::size_t i = 0; i < rows.size(); ++i) deviation[i] = std::abs(residual[i] - m);
    const double sigma = std::max(1.4826 * median(deviation), 1e-12);
    bool changed = false;
    for (std::size_t i = 0; i < rows.size(); ++i) {
      const bool keep = deviation[i] <= options.outlier_sigmas * sigma;
      changed = changed || keep != in[i];
      in[i] = keep;
    }
    if (!changed) break;
  }
  f = fit(rows, in, gyro, coupled, f->x(2), max_latency, step);
  if (!f || !(f->x(0) > 0.0)) return GyroCalibrationError::kNoCorrelation;
  const double alpha = f->x(0), beta = f->x(1);
  out.scale = 1.0 / alpha;
  out.bias = -beta / alpha;
  out.latency = f->x(2);
  out.coupling = f->x.tail<2>();

  // 3. Covariance of x: white, and the sandwich over blocks of block_time.
  Mat5 a = Mat5::Zero(), blocks = Mat5::Zero();
  Vec5 block = Vec5::Zero(), j;
  double block_end = rows.front().t1 + options.block_time;
  int n_blocks = 0;
  std::size_t used = 0;
  double ssr = 0.0;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    if (rows[i].t1 > block_end) {
      if (!block.isZero()) {
        blocks += block * block.transpose();
        ++n_blocks;
      }
      block.setZero();
      while (rows[i].t1 > block_end) block_end += options.block_time;
    }
    if (!in[i]) continue;
    const double r = residual_of(gyro, rows[i], f->x, &j);
    a += j * j.transpose();
    block += j * r;
    ssr += r * r;
    ++used;
  }
  if (!block.isZero()) {
    blocks += block * block.transpose();
    ++n_blocks;
  }
  out.rows_rejected = rows.size() - used;
  if (used < 20) return GyroCalibrationError::kTooFewRows;
  const int p = coupled ? 5 : 3;
  const double dof = static_cast<double>(used) - p;
  out.residual_rms = std::sqrt(ssr / static_cast<double>(used));
  const Eigen::MatrixXd a_inv = a.topLeftCorner(p, p).inverse();
  const Eigen::MatrixXd white = (ssr / dof) * a_inv;
  if (!white.allFinite()) return GyroCalibrationError::kNoRotation;
  Eigen::MatrixXd cov = white;
  if (n_blocks >= 10) {
    const Eigen::MatrixXd sandwich = a_inv * blocks.topLeftCorner(p, p) * a_inv;
    Eigen::VectorXd d(p);
    for (int q = 0; q < p; ++q) {
      d(q) = std::max(1.0, std::sqrt(white(q, q) / std::max(sandwich(q, q), 1e-300)));
    }
    cov = d.asDiagonal() * sandwich * d.asDiagonal();
    out.blocks = n_blocks;
  }
  // (k, c, L) from (alpha, beta, L): k = 1 / alpha, c = -beta / alpha.
  Eigen::Matrix3d to_kcl = Eigen::Matrix3d::Zero();
  to_kcl(0, 0) = -1.0 / (alpha * alpha);
  to_kcl(1, 0) = beta / (alpha * alpha);
  to_kcl(1, 1) = -1.0 / alpha;
  to_kcl(2, 2) = 1.0;
  out.covariance = to_kcl * cov.topLeftCorner<3, 3>() * to_kcl.transpose();
  return out;
}

}  // namespace moa
