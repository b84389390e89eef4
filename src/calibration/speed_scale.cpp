#include "moa/calibration/speed_scale.hpp"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace moa {
namespace {

// h_k(s) of the knots' hat functions (header comment) into h.
void hats(const std::vector<double>& knots, double s, Eigen::VectorXd& h) {
  const auto n = static_cast<Eigen::Index>(knots.size());
  h.setZero(n);
  if (s <= knots.front()) {
    h(0) = 1.0;
    return;
  }
  if (s >= knots.back()) {
    h(n - 1) = 1.0;
    return;
  }
  Eigen::Index j = 0;
  while (s >= knots[static_cast<std::size_t>(j + 1)]) ++j;
  const double a = knots[static_cast<std::size_t>(j)];
  const double b = knots[static_cast<std::size_t>(j + 1)];
  const double u = (s - a) / (b - a);
  h(j) = 1.0 - u;
  h(j + 1) = u;
}

SpeedScale table_of(const std::vector<double>& knots, const std::vector<double>& ratios) {
  std::array<real, SpeedScale::kMaxKnots> s{}, r{};
  const int n = static_cast<int>(std::min<std::size_t>(knots.size(), SpeedScale::kMaxKnots));
  for (int k = 0; k < n; ++k) {
    s[static_cast<std::size_t>(k)] = static_cast<real>(knots[static_cast<std::size_t>(k)]);
    r[static_cast<std::size_t>(k)] = static_cast<real>(ratios[static_cast<std::size_t>(k)]);
  }
  return SpeedScale(s.data(), r.data(), static_cast<int>(knots.size()),
                    static_cast<int>(ratios.size()));
}

// The knots alone: a table of ratio 1 must be accepted.
std::optional<SpeedScaleError> check_knots(const std::vector<double>& knots) {
  const SpeedScale table = table_of(knots, std::vector<double>(knots.size(), 1.0));
  if (const auto e = table.error()) {
    SpeedScaleError error;
    error.kind = SpeedScaleError::Kind::kBadKnots;
    error.table = *e;
    error.knot = table.error_knot();
    return error;
  }
  return std::nullopt;
}

}  // namespace

std::string SpeedScaleError::message(std::span<const std::string> names) const {
  const std::string who = sensor < 0 ? std::string()
                          : static_cast<std::size_t>(sensor) < names.size()
                              ? fmt::format("sensor '{}'", names[static_cast<std::size_t>(sensor)])
                              : fmt::format("sensor {}", sensor + 1);
  switch (kind) {
    case Kind::kBadKnots:
      return fmt::format("the knots: {}", table ? describe(*table) : "invalid");
    case Kind::kNotCovered:
      return fmt::format(
          "{}: knot {} m/s not covered by the data: {} windows near it, needs {} (the "
          "sensor's fastest window: {:.3g} m/s)",
          who, knot_speed, coverage, needed, max_speed);
    case Kind::kSingular:
      return fmt::format("{}: the knots' least squares is singular (windows too few or too alike)",
                         who);
    case Kind::kBadTable:
      return fmt::format("{}: the fitted table is refused: {}", who,
                         table ? describe(*table) : "invalid");
  }
  return "speed scale: unknown error";
}

std::variant<std::vector<SpeedScaleFit>, SpeedScaleError> fit_speed_scales(
    const SensorArray& array, std::span<const CalibrationSample> samples,
    const SpeedScaleOptions& options) {
  if (const auto e = check_knots(options.knots)) return *e;
  const auto nk = static_cast<Eigen::Index>(options.knots.size());
  std::vector<SpeedScaleFit> fits;
  Eigen::VectorXd h(nk);
  for (int i = 0; i < array.size(); ++i) {
    const SensorMount& m = array[i];
    const Eigen::Matrix<double, 2, 3> a = m.point_jacobian();
    const Eigen::Matrix2d to_metres = m.robot_velocity_from_counts();
    std::vector<double> ys;
    std::vector<Eigen::VectorXd> rows;
    SpeedScaleFit fit;
    fit.knots = options.knots;
    Eigen::VectorXd coverage = Eigen::VectorXd::Zero(nk);
    for (const CalibrationSample& sample : samples) {
      if (!usable_sample(sample, array.size())) continue;
      const double dt = sample.mice.dt;
      const Eigen::Vector2d d_true = a * (sample.reference.vector() * dt);  // m
      const double length = d_true.norm();
      const double s = length / dt;  // m/s
      if (!(s >= options.min_speed)) continue;
      const Eigen::Vector2d d_counted = to_metres * sample.mice.counts[static_cast<std::size_t>(i)];
      hats(options.knots, s, h);
      // Near knot k: nearer to it than to any other knot (h_k >= 1/2).
      coverage += (h.array() >= 0.5).cast<double>().matrix();
      rows.emplace_back(h * length);
      ys.push_back(d_true.dot(d_counted) / length);
      fit.max_speed = std::max(fit.max_speed, s);
    }
    for (Eigen::Index k = 0; k < nk; ++k) {
      if (!(coverage(k) >= options.min_windows)) {
        SpeedScaleError e;
        e.kind = SpeedScaleError::Kind::kNotCovered;
        e.sensor = i;
        e.knot = static_cast<int>(k);
        e.knot_speed = options.knots[static_cast<std::size_t>(k)];
        e.coverage = coverage(k);
        e.needed = options.min_windows;
        e.max_speed = fit.max_speed;
        return e;
      }
    }
    Eigen::MatrixXd xtx = Eigen::MatrixXd::Zero(nk, nk);
    Eigen::VectorXd xty = Eigen::VectorXd::Zero(nk);
    for (std::size_t w = 0; w < rows.size(); ++w) {
      xtx.noalias() += rows[w] * rows[w].transpose();
      xty += rows[w] * ys[w];
    }
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(xtx);
    const auto singular = [&] {
      SpeedScaleError e;
      e.kind = SpeedScaleError::Kind::kSingular;
      e.sensor = i;
      return e;
    };
    if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 0.0) ||
        rows.size() <= static_cast<std::size_t>(nk)) {
      return singular();
    }
    const Eigen::VectorXd r = ldlt.solve(xty);
    double rss = 0.0;
    for (std::size_t w = 0; w < rows.size(); ++w) {
      const double e = ys[w] - rows[w].dot(r);
      rss += e * e;
    }
    const double dof = static_cast<double>(rows.size()) - static_cast<double>(nk);
    const Eigen::MatrixXd cov =
        (rss / dof) * ldlt.solve(Eigen::MatrixXd::Identity(nk, nk));  // of r
    if (!r.allFinite() || !(r(0) > 0.0)) return singular();
    fit.first_ratio = r(0);
    fit.windows = static_cast<int>(rows.size());
    fit.residual_rms = std::sqrt(rss / static_cast<double>(rows.size()));
    for (Eigen::Index k = 0; k < nk; ++k) {
      const double q = r(k) / r(0);
      const double var = (cov(k, k) - 2.0 * q * cov(k, 0) + q * q * cov(0, 0)) / (r(0) * r(0));
      fit.ratios.push_back(q);
      fit.sigma.push_back(k == 0 ? 0.0 : std::sqrt(std::max(var, 0.0)));
      fit.coverage.push_back(coverage(k));
    }
    fits.push_back(std::move(fit));
  }
  return fits;
}

std::vector<CalibrationSample> undo_speed_scales(const SensorArray& array,
                                                 std::span<const CalibrationSample> samples) {
  std::vector<CalibrationSample> out(samples.begin(), samples.end());
  std::vector<Mat2> to_metres;
  for (int i = 0; i < array.size(); ++i) to_metres.push_back(array[i].robot_velocity_from_counts());
  for (CalibrationSample& s : out) {
    for (int i = 0; i < std::min(array.size(), s.mice.size); ++i) {
      const auto u = static_cast<std::size_t>(i);
      s.mice.counts[u] =
          corrected_counts(array[i].speed_scale, to_metres[u], s.mice.counts[u], s.mice.dt);
    }
  }
  return out;
}

std::variant<SpeedScaleCalibration, CalibrationError, SpeedScaleError> calibrate_exact_speed_scale(
    const SensorArray& nominal, std::span<const CalibrationSample> samples,
    const SpeedScaleOptions& options, const ExactOptions& exact_options) {
  if (const auto e = check_knots(options.knots)) return *e;
  SensorArray start = nominal;
  for (int i = 0; i < start.size(); ++i) start[i].speed_scale = SpeedScale{};
  std::vector<CalibrationSample> corrected(samples.begin(), samples.end());
  SpeedScaleCalibration out;
  std::vector<SpeedScaleFit> previous;
  std::vector<Vec2> previous_scale;
  for (int round = 1; round <= std::max(1, options.max_rounds); ++round) {
    auto fitted = calibrate_exact(start, corrected, exact_options);
    if (const auto* e = std::get_if<CalibrationError>(&fitted)) return *e;
    ExactCalibration exact = std::get<ExactCalibration>(std::move(fitted));
    for (int i = 0; i < exact.calibrated.size(); ++i) {
      exact.calibrated[i].speed_scale = SpeedScale{};
    }
    auto tables = fit_speed_scales(exact.calibrated, samples, options);
    if (const auto* e = std::get_if<SpeedScaleError>(&tables)) return *e;
    std::vector<SpeedScaleFit> fits = std::get<std::vector<SpeedScaleFit>>(std::move(tables));
    // The gauge (header comment): the scale takes r_0, the table is 1 at s_0.
    // `moved`: the largest change since the last round in units of its
    // 1-sigma (each ratio's, each scale's; the gauge r_0 - 1 in the sensor's
    // smallest ratio sigma).
    double moved = 0.0;
    std::vector<Vec2> scales;
    for (int i = 0; i < exact.calibrated.size(); ++i) {
      const auto u = static_cast<std::size_t>(i);
      SpeedScaleFit& fit = fits[u];
      const SpeedScale table = table_of(fit.knots, fit.ratios);
      if (const auto e = table.error()) {
        SpeedScaleError error;
        error.kind = SpeedScaleError::Kind::kBadTable;
        error.sensor = i;
        error.table = *e;
        return error;
      }
      SensorMount& m = exact.calibrated[i];
      m.scale *= fit.first_ratio;
      m.speed_scale = table;
      exact.sensors[u].calibrated.scale *= fit.first_ratio;
      exact.sensors[u].calibrated.speed_scale = table;
      scales.push_back(m.scale);
      double smallest = std::numeric_limits<double>::infinity();
      for (std::size_t k = 1; k < fit.sigma.size(); ++k)
        smallest = std::min(smallest, fit.sigma[k]);
      moved = std::max(moved, std::abs(fit.first_ratio - 1.0) / smallest);
      if (!previous.empty()) {
        for (std::size_t k = 1; k < fit.ratios.size(); ++k) {
          moved = std::max(moved, std::abs(fit.ratios[k] - previous[u].ratios[k]) / fit.sigma[k]);
        }
        const MountMatrix& cov = exact.sensors[u].covariance;
        for (int a = 0; a < 2; ++a) {
          const double sd = std::sqrt(cov(3 + a, 3 + a));
          if (sd > 0.0) moved = std::max(moved, std::abs(m.scale(a) - previous_scale[u](a)) / sd);
        }
      }
    }
    corrected = undo_speed_scales(exact.calibrated, samples);
    out.exact = std::move(exact);
    out.fits = fits;
    out.rounds = round;
    previous = std::move(fits);
    previous_scale = std::move(scales);
    // Settled: the last round moved nothing by more than a small part of its
    // 1-sigma: further rounds change nothing the data can tell.
    if (round > 1 && moved <= options.settle) {
      out.converged = true;
      break;
    }
  }
  return out;
}

}  // namespace moa
