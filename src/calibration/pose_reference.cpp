#include "moa/calibration/pose_reference.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "moa/calibration/lag_search.hpp"

namespace moa {

const char* describe(PoseReferenceError error) {
  switch (error) {
    case PoseReferenceError::kTooFewFixes:
      return "fewer than 20 windows between fixes within the time span of the sensors' rows";
    case PoseReferenceError::kBadInput:
      return "fix stamps that do not increase or values that are not finite";
    case PoseReferenceError::kNoCorrelation:
      return "the sensors' speeds do not correlate with the reference's at any latency within "
             "the search range: not the same motion (a reference from another run) or clocks "
             "further apart (--max-offset)";
    case PoseReferenceError::kCalibration:
      return "the exact calibration refused the windows";
  }
  return "calibration against poses error";
}

// ------------------------------------------------------------ CountsTrack

void CountsTrack::add(double t, const Eigen::Vector2d& counts, bool flagged) {
  if (knots_.empty()) knots_.push_back({t - max_row_interval_, Eigen::Vector2d::Zero(), 0});
  Knot& last = knots_.back();
  if (!(t > last.t)) {  // a repeated stamp: its counts at the same instant
    last.c += counts;
    last.flags += flagged ? 1 : 0;
    return;
  }
  const double a = std::max(last.t, t - max_row_interval_);
  if (a > last.t) knots_.push_back({a, last.c, last.flags});
  const Knot& prev = knots_.back();
  knots_.push_back({t, prev.c + counts, prev.flags + (flagged ? 1 : 0)});
}

std::size_t CountsTrack::segment(double t) const {
  const auto it = std::upper_bound(knots_.begin(), knots_.end(), t,
                                   [](double x, const Knot& k) { return x < k.t; });
  const auto j = static_cast<std::size_t>(std::max<std::ptrdiff_t>(it - knots_.begin(), 1)) - 1;
  return std::min(j, knots_.size() - 2);
}

Eigen::Vector2d CountsTrack::between(double a, double b) const {
  const auto at = [&](double t) -> Eigen::Vector2d {
    const std::size_t j = segment(t);
    const Knot& k0 = knots_[j];
    const Knot& k1 = knots_[j + 1];
    const double span = k1.t - k0.t;
    const double f = span > 0.0 ? std::clamp((t - k0.t) / span, 0.0, 1.0) : 1.0;
    return k0.c + f * (k1.c - k0.c);
  };
  return at(b) - at(a);
}

Eigen::Vector2d CountsTrack::rate(double t) const {
  const std::size_t j = segment(t);
  const double span = knots_[j + 1].t - knots_[j].t;
  return span > 0.0 ? Eigen::Vector2d((knots_[j + 1].c - knots_[j].c) / span)
                    : Eigen::Vector2d::Zero();
}

bool CountsTrack::flagged(double a, double b) const {
  return knots_[segment(b) + 1].flags > knots_[segment(a)].flags;
}

// ------------------------------------------------------------ calibration

namespace {

// Fixes stamped t_a < t_b, at least options.window apart (consecutive
// fixes merged), and the reference's displacement log(T_a^-1 T_b).
struct Window {
  double ta = 0.0, tb = 0.0;
  Eigen::Vector3d z = Eigen::Vector3d::Zero();  // m, m, rad (robot frame at t_a)
};

constexpr double kLagStep = 0.005;      // s, coarse grid
constexpr double kMaxWindowFactor = 3;  // windows longer than this x window (dropped fixes): not used
constexpr double kMaxLatencyStep = 0.02;  // s, per Gauss-Newton step
constexpr int kMinWindows = 20;
constexpr int kMinLongWindows = 10;  // of the common offset's fit (one parameter, S 3x3)

// z = (integral of the body-frame velocity, integral of omega) between
// fixes s and e: sum_j R(-theta_j') (p_{j+1} - p_j), theta_j' the mean of
// the two fixes' headings (unwrapped), and theta_e - theta_s. Exact for
// the path through the fixes (piecewise straight at the fixes' rate),
// whatever the twist does over the window.
std::vector<Window> windows_of(std::span<const PoseFix> fixes, double window) {
  std::vector<Window> out;
  std::size_t s = 0;
  while (s + 1 < fixes.size()) {
    std::size_t e = s + 1;
    while (e < fixes.size() && fixes[e].t - fixes[s].t < window) ++e;
    if (e >= fixes.size()) break;
    const double dt = fixes[e].t - fixes[s].t;
    if (dt <= kMaxWindowFactor * window) {
      Window w;
      w.ta = fixes[s].t;
      w.tb = fixes[e].t;
      double theta = fixes[s].pose.theta;
      for (std::size_t j = s; j < e; ++j) {
        const double step = wrap_angle(fixes[j + 1].pose.theta - fixes[j].pose.theta);
        const Eigen::Vector2d dp = fixes[j + 1].pose.t - fixes[j].pose.t;
        w.z.head<2>() += rotation(-(theta + 0.5 * step)) * dp;
        theta += step;
      }
      w.z(2) = theta - fixes[s].pose.theta;
      out.push_back(w);
    }
    s = e;
  }
  return out;
}

// Sensor i's counts over window w at clock offset d_i (= L_i - L_r).
bool covered(const CountsTrack& track, const Window& w, double d, double margin) {
  return w.ta + d - margin >= track.front() && w.tb + d + margin <= track.back();
}

// Exact calibration samples at offsets d (windows every track covers, unflagged).
std::vector<CalibrationSample> samples_at(std::span<const CountsTrack> tracks,
                                          const std::vector<Window>& windows,
                                          const std::vector<double>& d) {
  const int n = static_cast<int>(tracks.size());
  std::vector<CalibrationSample> out;
  for (const Window& w : windows) {
    bool ok = true;
    for (int i = 0; i < n && ok; ++i) {
      const auto u = static_cast<std::size_t>(i);
      ok = covered(tracks[u], w, d[u], 0.0) && !tracks[u].flagged(w.ta + d[u], w.tb + d[u]);
    }
    if (!ok) continue;
    CalibrationSample s;
    s.mice.t = w.tb;
    s.mice.dt = w.tb - w.ta;
    s.mice.size = n;
    for (int i = 0; i < n; ++i) {
      const auto u = static_cast<std::size_t>(i);
      s.mice.counts[u] = tracks[u].between(w.ta + d[u], w.tb + d[u]);
    }
    s.reference = Twist2::from_vector(w.z / (w.tb - w.ta));
    out.push_back(s);
  }
  return out;
}

using Stack = Eigen::Matrix<double, Eigen::Dynamic, 3>;

// The count rows of `array` stacked (2N x 3), without sensor `skip`.
Stack stack(const SensorArray& array, int skip = -1) {
  Stack h(2 * (array.size() - (skip >= 0 ? 1 : 0)), 3);
  int row = 0;
  for (int i = 0; i < array.size(); ++i) {
    if (i == skip) continue;
    h.middleRows<2>(row) = array[i].twist_jacobian();
    row += 2;
  }
  return h;
}

// Every sensor's counts (c) and the change of its count rate (j, counts/s)
// over window w at offsets d + e; false when a track does not cover it
// (with `margin`) or a row in it is flagged.
bool window_counts(std::span<const CountsTrack> tracks, const Window& w,
                   const std::vector<double>& d, double e, double margin, Eigen::VectorXd& c,
                   Eigen::VectorXd& j) {
  const auto n = static_cast<Eigen::Index>(tracks.size());
  c.resize(2 * n);
  j.resize(2 * n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto u = static_cast<std::size_t>(i);
    const double a = w.ta + d[u] + e, b = w.tb + d[u] + e;
    if (!covered(tracks[u], w, d[u] + e, margin) || tracks[u].flagged(a, b)) return false;
    c.segment<2>(2 * i) = tracks[u].between(a, b);
    j.segment<2>(2 * i) = tracks[u].rate(b) - tracks[u].rate(a);
  }
  return true;
}

Eigen::VectorXd without(const Eigen::VectorXd& x, int skip) {
  Eigen::VectorXd out(x.size() - 2);
  out << x.head(2 * skip), x.tail(x.size() - 2 * skip - 2);
  return out;
}

// Sensor i's offset d_i by Gauss-Newton on r_k = c_ik(d_i) - H_i z_k, z_k
// the other sensors' least-squares displacement at their offsets (with
// three or more sensors: their noise is the counts', not the reference's),
// else the reference's; returns the information sum |dr/dd|^2 / sigma^2
// (s^-2) at the last step.
double fit_offset(std::span<const CountsTrack> tracks, const SensorArray& array,
                  const std::vector<Window>& windows, std::vector<double>& d, int i) {
  const auto u = static_cast<std::size_t>(i);
  const bool others = array.size() >= 3;
  const Eigen::Matrix<double, 2, 3> hi = array[i].twist_jacobian();
  const Stack h = stack(array, i);
  const Eigen::Matrix<double, 3, Eigen::Dynamic> ls = (h.transpose() * h).inverse() * h.transpose();
  double information = 0.0;
  Eigen::VectorXd c, j;
  for (int step = 0; step < 8; ++step) {
    double jj = 0.0, jr = 0.0, rr = 0.0;
    int k = 0;
    for (const Window& w : windows) {
      if (!window_counts(tracks, w, d, 0.0, kMaxLatencyStep, c, j)) continue;
      const Eigen::Vector3d z = others ? Eigen::Vector3d(ls * without(c, i)) : w.z;
      const Eigen::Vector2d r = c.segment<2>(2 * i) - hi * z;
      const Eigen::Vector2d ji = j.segment<2>(2 * i);
      jj += ji.squaredNorm();
      jr += ji.dot(r);
      rr += r.squaredNorm();
      ++k;
    }
    if (k < kMinWindows || !(jj > 0.0)) return 0.0;
    information = jj / (rr / (2.0 * k - 1.0));
    const double delta = std::clamp(-jr / jj, -kMaxLatencyStep, kMaxLatencyStep);
    d[u] += delta;
    if (std::abs(delta) < 1e-7) break;
  }
  return information;
}

// The offset e common to all sensors (the reference's latency against the
// array) by Gauss-Newton on r_k = z_k - P c_k(d + e), P the array's least
// squares, weighted by the residuals' own covariance S; returns
// sum_k J_k^T S^-1 J_k (s^-2), J_k = P j_k.
double fit_common_offset(std::span<const CountsTrack> tracks, const SensorArray& array,
                         const std::vector<Window>& windows, std::vector<double>& d) {
  const Stack h = stack(array);
  const Eigen::Matrix<double, 3, Eigen::Dynamic> ls = (h.transpose() * h).inverse() * h.transpose();
  double e = 0.0, information = 0.0;
  Eigen::VectorXd c, j;
  for (int step = 0; step < 8; ++step) {
    std::vector<Eigen::Vector3d> r, jz;
    for (const Window& w : windows) {
      if (!window_counts(tracks, w, d, e, kMaxLatencyStep, c, j)) continue;
      r.emplace_back(w.z - ls * c);
      jz.emplace_back(ls * j);
    }
    const auto k = static_cast<int>(r.size());
    if (k < kMinLongWindows) return 0.0;
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (const auto& x : r) cov += x * x.transpose();
    cov /= k - 1.0;
    const Eigen::FullPivLU<Eigen::Matrix3d> lu(cov);
    if (!lu.isInvertible()) return 0.0;
    const Eigen::Matrix3d weight = lu.inverse();
    double a = 0.0, b = 0.0;
    for (int m = 0; m < k; ++m) {
      const auto u = static_cast<std::size_t>(m);
      a += jz[u].dot(weight * jz[u]);
      b += jz[u].dot(weight * r[u]);
    }
    if (!(a > 0.0)) return 0.0;
    information = a;
    const double delta = std::clamp(b / a, -kMaxLatencyStep, kMaxLatencyStep);
    e += delta;
    if (std::abs(delta) < 1e-7) break;
  }
  for (double& x : d) x += e;
  return information;
}

}  // namespace

std::variant<PoseReferenceCalibration, PoseReferenceFailure> calibrate_against_poses(
    const SensorArray& nominal, std::span<const CountsTrack> tracks,
    std::span<const double> latency, std::span<const PoseFix> fixes, double reference_latency,
    const PoseReferenceOptions& options) {
  const auto fail = [](PoseReferenceError e) { return PoseReferenceFailure{e, std::nullopt}; };
  const int n = nominal.size();
  if (static_cast<int>(tracks.size()) != n || static_cast<int>(latency.size()) != n) {
    return fail(PoseReferenceError::kBadInput);
  }
  for (std::size_t k = 0; k < fixes.size(); ++k) {
    const PoseFix& f = fixes[k];
    if (!std::isfinite(f.t) || !f.pose.t.allFinite() || !std::isfinite(f.pose.theta) ||
        (k > 0 && !(f.t > fixes[k - 1].t))) {
      return fail(PoseReferenceError::kBadInput);
    }
  }
  for (const CountsTrack& t : tracks) {
    if (t.empty()) return fail(PoseReferenceError::kTooFewFixes);
  }
  const std::vector<Window> windows = windows_of(fixes, options.window);

  // 1. Coarse: the reference's latency L_r by the speeds' correlation.
  const double m = options.max_offset;
  std::vector<const Window*> in_range;
  for (const Window& w : windows) {
    bool ok = true;
    for (int i = 0; i < n && ok; ++i) {
      const auto u = static_cast<std::size_t>(i);
      ok = covered(tracks[u], w, latency[u] - reference_latency, m);
    }
    if (ok) in_range.push_back(&w);
  }
  if (static_cast<int>(in_range.size()) < kMinWindows) return fail(PoseReferenceError::kTooFewFixes);
  // Per window and sensor: the sensor point's speed by the reference at the
  // nominal position, |z_xy + z_theta J p_i| / dt, against the sensor's own,
  // |c_i| / (k_i dt) (neither yaw nor mirroring changes it).
  const int lags = static_cast<int>(std::ceil(m / kLagStep));
  std::vector<double> ref_speed, array_speed, c;
  for (const Window* w : in_range) {
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector2d p = nominal[i].position;
      const Eigen::Vector2d v = w->z.head<2>() + w->z(2) * Eigen::Vector2d(-p.y(), p.x());
      ref_speed.push_back(v.norm() / (w->tb - w->ta));
    }
  }
  array_speed.resize(ref_speed.size());
  for (int j = -lags; j <= lags; ++j) {
    const double lr = reference_latency + j * kLagStep;
    std::size_t row = 0;
    for (const Window* w : in_range) {
      for (int i = 0; i < n; ++i) {
        const auto u = static_cast<std::size_t>(i);
        const double d = latency[u] - lr;
        array_speed[row++] = tracks[u].between(w->ta + d, w->tb + d).norm() /
                             (nominal[i].counts_per_metre() * (w->tb - w->ta));
      }
    }
    c.push_back(pearson_correlation(array_speed, ref_speed));
  }
  const auto peak = correlation_peak(c, kLagStep, options.min_correlation);
  PoseReferenceCalibration out;
  out.correlation = *std::max_element(c.begin(), c.end());
  if (!peak) {
    return PoseReferenceFailure{PoseReferenceError::kNoCorrelation, std::nullopt, out.correlation};
  }
  out.coarse_latency = reference_latency + peak->lag;

  // 2. Mounts and offsets alternating, then the gauge.
  std::vector<double> d(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    d[static_cast<std::size_t>(i)] = latency[static_cast<std::size_t>(i)] - out.coarse_latency;
  }
  std::vector<double> information(static_cast<std::size_t>(n), 0.0);
  double common_information = 0.0;
  // Long windows, halved down to twice the mounts' window while there are
  // fewer than 2 kMinLongWindows of them (a short log).
  double long_window = options.latency_window;
  std::vector<Window> long_windows = windows_of(fixes, long_window);
  while (static_cast<int>(long_windows.size()) < 2 * kMinLongWindows &&
         long_window > 2.0 * options.window) {
    long_window *= 0.5;
    long_windows = windows_of(fixes, long_window);
  }
  const auto calibrate = [&]() -> std::variant<ExactCalibration, CalibrationError> {
    const std::vector<CalibrationSample> s = samples_at(tracks, windows, d);
    out.windows = static_cast<int>(s.size());
    return calibrate_exact(nominal, s, options.exact);
  };
  for (int iter = 0; iter < options.iterations; ++iter) {
    auto cal = calibrate();
    if (const auto* e = std::get_if<CalibrationError>(&cal)) {
      return PoseReferenceFailure{PoseReferenceError::kCalibration, *e, out.correlation};
    }
    const SensorArray& array = std::get<ExactCalibration>(cal).calibrated;
    for (int sweep = 0; sweep < 3; ++sweep) {
      for (int i = 0; i < n; ++i) {
        const auto u = static_cast<std::size_t>(i);
        std::vector<double> trial = d;
        information[u] = fit_offset(tracks, array, windows, trial, i);
        if (information[u] >= options.min_latency_information) d[u] = trial[u];
      }
    }
    std::vector<double> trial = d;
    common_information = fit_common_offset(tracks, array, long_windows, trial);
    if (common_information >= options.min_latency_information) d = trial;
  }
  auto cal = calibrate();
  if (const auto* e = std::get_if<CalibrationError>(&cal)) {
    return PoseReferenceFailure{PoseReferenceError::kCalibration, *e, out.correlation};
  }
  out.exact = std::get<ExactCalibration>(std::move(cal));

  // Gauge: the estimated sensors' mean latency as configured.
  out.latency.assign(latency.begin(), latency.end());
  out.latency_sigma.assign(static_cast<std::size_t>(n), 0.0);
  out.latency_estimated.assign(static_cast<std::size_t>(n), false);
  double mean_configured = 0.0, mean_offset = 0.0, sum_variance = 0.0;
  int estimated = 0;
  for (int i = 0; i < n; ++i) {
    const auto u = static_cast<std::size_t>(i);
    if (!(information[u] >= options.min_latency_information)) continue;
    out.latency_estimated[u] = true;
    mean_configured += latency[u];
    mean_offset += d[u];
    sum_variance += 1.0 / information[u];
    ++estimated;
  }
  if (estimated == 0) {
    out.reference_latency = out.coarse_latency;
    out.reference_latency_sigma = kLagStep;
    return out;
  }
  mean_configured /= estimated;
  mean_offset /= estimated;
  out.reference_latency = mean_configured - mean_offset;
  // The common offset not seen (no acceleration over the long windows): as
  // the coarse alignment left it, to its grid.
  out.reference_latency_sigma =
      common_information >= options.min_latency_information
          ? std::sqrt(1.0 / common_information + sum_variance / (estimated * estimated))
          : kLagStep;
  for (int i = 0; i < n; ++i) {
    const auto u = static_cast<std::size_t>(i);
    if (!out.latency_estimated[u]) continue;
    out.latency[u] = out.reference_latency + d[u];
    out.latency_sigma[u] = 1.0 / std::sqrt(information[u]);
  }
  return out;
}

}  // namespace moa
