#include "moa/calibration/pose_reference.hpp"

#include <Eigen/Cholesky>
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

constexpr double kLagStep = 0.005;  // s, coarse grid
constexpr double kMaxWindowFactor =
    3;  // windows longer than this x window (dropped fixes): not used
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

bool valid_fix_times(std::span<const double> t) {
  for (std::size_t k = 0; k < t.size(); ++k) {
    if (!std::isfinite(t[k]) || (k > 0 && !(t[k] > t[k - 1]))) return false;
  }
  return true;
}

// calibrate_against_poses; `positions`: the fixes' headings come from the
// array (calibrate_against_positions), which has found L_r itself: no
// coarse search, no common offset (the rotation is the array's own, the
// translation's windows too few), only the mounts and the offsets d_i.
std::variant<PoseReferenceCalibration, PoseReferenceFailure> fit_poses(
    const SensorArray& nominal, std::span<const CountsTrack> tracks,
    std::span<const double> latency, std::span<const PoseFix> fixes, double reference_latency,
    const PoseReferenceOptions& options, bool positions) {
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

  PoseReferenceCalibration out;
  out.coarse_latency = reference_latency;
  if (!positions) {
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
    if (static_cast<int>(in_range.size()) < kMinWindows)
      return fail(PoseReferenceError::kTooFewFixes);
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
    out.correlation = *std::max_element(c.begin(), c.end());
    if (!peak) {
      return PoseReferenceFailure{PoseReferenceError::kNoCorrelation, std::nullopt,
                                  out.correlation};
    }
    out.coarse_latency = reference_latency + peak->lag;
  }

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
    const double mean_before = std::accumulate(d.begin(), d.end(), 0.0) / n;
    for (int sweep = 0; sweep < 3; ++sweep) {
      for (int i = 0; i < n; ++i) {
        const auto u = static_cast<std::size_t>(i);
        std::vector<double> trial = d;
        information[u] = fit_offset(tracks, array, windows, trial, i);
        if (information[u] >= options.min_latency_information) d[u] = trial[u];
      }
    }
    if (positions) {
      // Each d_i is fitted against the others: only their differences are
      // seen here, so their mean (the common offset, the caller's) is kept.
      const double shift = std::accumulate(d.begin(), d.end(), 0.0) / n - mean_before;
      for (double& x : d) x -= shift;
      continue;
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

// ------------------------------------------------------------ positions only

constexpr double kMinRotationRange = 0.5;  // rad, least range of Theta to fit epsilon
constexpr int kPositionPasses = 12;        // at most: heading / poses / gauge passes
constexpr double kPassTolerance = 2e-5;    // s, passes stop when L_r moves less
// s, the common offset's segments (track_offset): long enough that the
// velocity varies within one beyond a line (a 2 s segment keeps about a
// fifth of the variation a 6 s one does), short enough that the dead
// reckoning's drift within it is a line.
constexpr double kTrackSegment = 5.0;

using LeastSquares = Eigen::Matrix<double, 3, Eigen::Dynamic>;

LeastSquares least_squares(const SensorArray& array) {
  const Stack h = stack(array);
  return (h.transpose() * h).inverse() * h.transpose();
}

// The array's displacement z = P c (m, m, rad; body frame at the start)
// over (a + d_i, b + d_i] of every track.
Eigen::Vector3d array_displacement(std::span<const CountsTrack> tracks, const LeastSquares& ls,
                                   std::span<const double> d, double a, double b) {
  Eigen::VectorXd c(2 * static_cast<Eigen::Index>(tracks.size()));
  for (std::size_t i = 0; i < tracks.size(); ++i) {
    c.segment<2>(2 * static_cast<Eigen::Index>(i)) = tracks[i].between(a + d[i], b + d[i]);
  }
  return ls * c;
}

// Fixes [lo, hi) every track covers at offsets d with `margin`: a contiguous
// range, since each track covers one interval.
std::pair<std::size_t, std::size_t> covered_fixes(std::span<const CountsTrack> tracks,
                                                  std::span<const PositionFix> fixes,
                                                  std::span<const double> d, double margin) {
  const auto inside = [&](double t) {
    for (std::size_t i = 0; i < tracks.size(); ++i) {
      if (t + d[i] - margin < tracks[i].front() || t + d[i] + margin > tracks[i].back()) {
        return false;
      }
    }
    return true;
  };
  std::size_t lo = 0;
  while (lo < fixes.size() && !inside(fixes[lo].t)) ++lo;
  std::size_t hi = lo;
  while (hi < fixes.size() && inside(fixes[hi].t)) ++hi;
  return {lo, hi};
}

// Windows of fixes [s, e] (indices into a range), at least `window` s and
// at most kMaxWindowFactor x window long.
std::vector<std::pair<std::size_t, std::size_t>> index_windows(std::span<const double> t,
                                                               double window) {
  std::vector<std::pair<std::size_t, std::size_t>> out;
  std::size_t s = 0;
  while (s + 1 < t.size()) {
    std::size_t e = s + 1;
    while (e < t.size() && t[e] - t[s] < window) ++e;
    if (e >= t.size()) break;
    if (t[e] - t[s] <= kMaxWindowFactor * window) out.emplace_back(s, e);
    s = e;
  }
  return out;
}

// Step 1 of the header: the heading of fixes t, p (one range) from the
// array's steps z (z[j] between fixes j and j + 1). Returns the fit and
// fills `theta` (rad, at each fix); nullopt with fewer than kMinWindows
// windows.
std::optional<HeadingFit> fit_heading(std::span<const double> t, std::span<const Eigen::Vector2d> p,
                                      const std::vector<Eigen::Vector3d>& z, double window,
                                      std::vector<double>& theta) {
  const std::size_t m = t.size();
  std::vector<double> big(m, 0.0);  // Theta_j
  for (std::size_t j = 0; j + 1 < m; ++j) big[j + 1] = big[j] + z[j](2);
  const auto windows = index_windows(t, window);
  if (static_cast<int>(windows.size()) < kMinWindows) return std::nullopt;
  HeadingFit fit;
  fit.windows = static_cast<int>(windows.size());
  fit.rotation_range =
      *std::max_element(big.begin(), big.end()) - *std::min_element(big.begin(), big.end());
  fit.rate_scale_estimated = fit.rotation_range >= kMinRotationRange;
  const Eigen::Index np = fit.rate_scale_estimated ? 3 : 2;  // theta_0, beta[, epsilon]
  const Eigen::Matrix2d turn{{0.0, -1.0}, {1.0, 0.0}};
  // theta_j' and its derivatives (theta_0, beta, epsilon)
  const auto heading = [&](std::size_t j, const Eigen::Vector3d& x) {
    return x(0) + x(1) * (t[j] - t[0]) + (1.0 + x(2)) * (big[j] + 0.5 * z[j](2));
  };
  Eigen::Vector3d x = Eigen::Vector3d::Zero();
  {  // theta_0 by Procrustes: the angle from the array's path to the camera's
    double cross = 0.0, dot = 0.0;
    for (const auto& [a, b] : windows) {
      Eigen::Vector2d u = Eigen::Vector2d::Zero();
      for (std::size_t j = a; j < b; ++j) u += rotation(heading(j, x)) * z[j].head<2>();
      const Eigen::Vector2d w = p[b] - p[a];
      cross += u.x() * w.y() - u.y() * w.x();
      dot += u.dot(w);
    }
    x(0) = std::atan2(cross, dot);
  }
  Eigen::MatrixXd jtj(np, np);
  double rr = 0.0;
  for (int iter = 0; iter < 10; ++iter) {
    jtj.setZero();
    Eigen::VectorXd jtr = Eigen::VectorXd::Zero(np);
    rr = 0.0;
    for (const auto& [a, b] : windows) {
      Eigen::Vector2d r = p[b] - p[a];
      Eigen::Matrix<double, 2, 3> jac = Eigen::Matrix<double, 2, 3>::Zero();
      for (std::size_t j = a; j < b; ++j) {
        const Eigen::Vector2d step = rotation(heading(j, x)) * z[j].head<2>();
        r -= step;
        const Eigen::Vector2d dstep = turn * step;  // d step / d theta_j'
        jac.col(0) -= dstep;
        jac.col(1) -= dstep * (t[j] - t[0]);
        jac.col(2) -= dstep * (big[j] + 0.5 * z[j](2));
      }
      const auto jn = jac.leftCols(np);
      jtj += jn.transpose() * jn;
      jtr += jn.transpose() * r;
      rr += r.squaredNorm();
    }
    const Eigen::VectorXd delta = jtj.ldlt().solve(-jtr);
    x.head(np) += delta;
    if (delta.cwiseAbs().maxCoeff() < 1e-10) break;
  }
  const double dof = 2.0 * static_cast<double>(windows.size()) - static_cast<double>(np);
  const double s2 = rr / dof;
  const Eigen::MatrixXd cov = s2 * jtj.inverse();
  fit.theta0 = x(0);
  fit.theta0_sigma = std::sqrt(cov(0, 0));
  fit.drift = x(1);
  fit.drift_sigma = std::sqrt(cov(1, 1));
  fit.rate_scale = x(2);
  fit.rate_scale_sigma = np == 3 ? std::sqrt(cov(2, 2)) : 0.0;
  fit.residual_rms = std::sqrt(s2);
  theta.resize(m);
  for (std::size_t j = 0; j < m; ++j) {
    theta[j] = wrap_angle(x(0) + x(1) * (t[j] - t[0]) + (1.0 + x(2)) * big[j]);
  }
  return fit;
}

// Step 3 of the header: the robot frame turned so that the sensors' mean
// yaw change is 0; returns delta (rad).
double apply_yaw_gauge(ExactCalibration& cal, const SensorArray& nominal) {
  const auto n = static_cast<Eigen::Index>(cal.sensors.size());
  // K: the sensors whose mirroring the data kept (a flip changes what the
  // yaw means); all of them when none is.
  std::vector<bool> in_mean(cal.sensors.size());
  int members = 0;
  for (int pass = 0; pass < 2 && members == 0; ++pass) {
    for (std::size_t i = 0; i < cal.sensors.size(); ++i) {
      in_mean[i] =
          pass == 1 || cal.sensors[i].calibrated.mirrored == nominal[static_cast<int>(i)].mirrored;
      members += in_mean[i] ? 1 : 0;
    }
  }
  double sin_sum = 0.0, cos_sum = 0.0;
  for (std::size_t i = 0; i < cal.sensors.size(); ++i) {
    if (!in_mean[i]) continue;
    const double change = wrap_angle(
        static_cast<double>(cal.sensors[i].calibrated.yaw - nominal[static_cast<int>(i)].yaw));
    sin_sum += std::sin(change);
    cos_sum += std::cos(change);
  }
  const double delta = std::atan2(sin_sum, cos_sum);
  const Eigen::Matrix2d back = rotation(-delta);
  const Eigen::Matrix2d turn90{{0.0, -1.0}, {1.0, 0.0}};
  // The map's Jacobian T (5N x 5N, parameters sensor-major in MountParameter
  // order): p_i' = R(-delta) p_i, yaw_i' = yaw_i - delta, delta the (circular,
  // ~arithmetic) mean of the yaw changes over K, d delta / d yaw_j = 1/|K|:
  //   d p_i' / d p_i = R(-delta),  d p_i' / d yaw_j = -J p_i' / |K|,
  //   d yaw_i' / d yaw_j = [i = j] - 1/|K|   (j in K).
  // Sigma' = T Sigma T^T: the common turn the data cannot see leaves the
  // yaws' 1-sigma (they become relative to their mean).
  Eigen::MatrixXd t = Eigen::MatrixXd::Identity(5 * n, 5 * n);
  std::vector<SensorMount> mounts;
  for (Eigen::Index i = 0; i < n; ++i) {
    SensorCalibration& s = cal.sensors[static_cast<std::size_t>(i)];
    s.calibrated.position = (back * s.calibrated.position.cast<double>()).cast<real>();
    s.calibrated.yaw = static_cast<real>(s.calibrated.yaw - delta);
    t.block<2, 2>(5 * i, 5 * i) = back;
    const Eigen::Vector2d lever = -turn90 * s.calibrated.position.cast<double>() / members;
    for (Eigen::Index j = 0; j < n; ++j) {
      if (!in_mean[static_cast<std::size_t>(j)]) continue;
      t.block<2, 1>(5 * i, 5 * j + 2) += lever;
      t(5 * i + 2, 5 * j + 2) -= 1.0 / members;
    }
    mounts.push_back(s.calibrated);
  }
  if (cal.covariance.rows() == 5 * n) {
    cal.covariance = t * cal.covariance * t.transpose();
    for (Eigen::Index i = 0; i < n; ++i) {
      cal.sensors[static_cast<std::size_t>(i)].covariance =
          cal.covariance.block<5, 5>(5 * i, 5 * i);
    }
  } else {
    for (Eigen::Index i = 0; i < n; ++i) {
      MountMatrix r = MountMatrix::Identity();
      r.topLeftCorner<2, 2>() = back;
      auto& c = cal.sensors[static_cast<std::size_t>(i)].covariance;
      c = r * c * r.transpose();
    }
  }
  cal.calibrated = SensorArray(mounts);
  return delta;
}

// The array's twist rate (m/s, m/s, rad/s; body frame) at fix time t:
// each track's row rate at t + d_i through the least squares.
Eigen::Vector3d array_rate(std::span<const CountsTrack> tracks, const LeastSquares& ls,
                           std::span<const double> d, double t) {
  Eigen::VectorXd c(2 * static_cast<Eigen::Index>(tracks.size()));
  for (std::size_t i = 0; i < tracks.size(); ++i) {
    c.segment<2>(2 * static_cast<Eigen::Index>(i)) = tracks[i].rate(t + d[i]);
  }
  return ls * c;
}

struct TrackOffset {
  double e = 0.0;            ///< s, to add to every d_i
  double information = 0.0;  ///< s^-2
};

// The common offset from the camera's positions against the array's path
// (positions only; the windows' end fixes alone see too little of it). Per
// segment of fixes s..f at least `segment` s long and per axis,
//   r_j = (p_j - p_s) - D_j = a + b (t_j - t_s) + V_j e + sum_k G_kj m_k + noise,
// D_j the array's world displacement from fix s to fix j (its steps turned
// by the heading), V_j its world velocity at fix j (a later clock moves
// the path along it); a and b take the start fix's error and a slow drift
// of the dead reckoning; m (4) a correction (I + M) of the array's
// body-frame translation, G_kj = sum_m R(theta_m') E_k z_m,xy (E_k the four
// unit 2x2 matrices): while the mounts are still off, the path's error is
// not taken for a clock offset. With a and b projected out of every column
// (per segment and axis), the normal equations A x = g of (e, m) summed;
// e = x_0, its information 1 / (s^2 (A^-1)_00), s^2 the residual variance.
TrackOffset track_offset(std::span<const double> t, std::span<const Eigen::Vector2d> p,
                         const std::vector<Eigen::Vector3d>& z, const std::vector<double>& theta,
                         const std::vector<Eigen::Vector3d>& rate, double segment) {
  Eigen::Matrix<double, 5, 5> a = Eigen::Matrix<double, 5, 5>::Zero();
  Eigen::Matrix<double, 5, 1> g = Eigen::Matrix<double, 5, 1>::Zero();
  double rr = 0.0;
  int dof = -5;
  std::size_t s = 0;
  std::vector<Eigen::Matrix<double, 2, 6>> rows;  // per fix: [V, G_1..G_4, r]
  while (s + 1 < t.size()) {
    std::size_t f = s + 1;
    while (f < t.size() && t[f] - t[s] < segment) ++f;
    if (f >= t.size()) break;
    rows.clear();
    Eigen::Vector2d travelled = Eigen::Vector2d::Zero();
    Eigen::Matrix<double, 2, 4> basis = Eigen::Matrix<double, 2, 4>::Zero();
    for (std::size_t j = s; j <= f; ++j) {
      if (j > s) {
        const std::size_t m = j - 1;
        const Eigen::Matrix2d turn = rotation(theta[m] + 0.5 * z[m](2));
        const Eigen::Vector2d step = z[m].head<2>();
        travelled += turn * step;
        // E_k z for E = (1,0;0,0), (0,1;0,0), (0,0;1,0), (0,0;0,1)
        basis.col(0) += turn.col(0) * step.x();
        basis.col(1) += turn.col(0) * step.y();
        basis.col(2) += turn.col(1) * step.x();
        basis.col(3) += turn.col(1) * step.y();
      }
      Eigen::Matrix<double, 2, 6> row;
      row.col(0) = rotation(theta[j]) * rate[j].head<2>();
      row.middleCols<4>(1) = basis;
      row.col(5) = p[j] - p[s] - travelled;
      rows.push_back(row);
    }
    const auto k = static_cast<Eigen::Index>(rows.size());
    if (k >= 8) {
      // Each column less its least-squares line in tau = t_j - t_s:
      // c~ = c - mean(c) - (tau - mean(tau)) S_tc / S_tt.
      double tau_mean = 0.0;
      for (Eigen::Index j = 0; j < k; ++j) tau_mean += t[s + static_cast<std::size_t>(j)] - t[s];
      tau_mean /= static_cast<double>(k);
      Eigen::VectorXd tau(k);
      for (Eigen::Index j = 0; j < k; ++j) {
        tau(j) = t[s + static_cast<std::size_t>(j)] - t[s] - tau_mean;
      }
      const double stt = tau.squaredNorm();
      for (int axis = 0; axis < 2; ++axis) {
        Eigen::MatrixXd c(k, 6);
        for (Eigen::Index j = 0; j < k; ++j) c.row(j) = rows[static_cast<std::size_t>(j)].row(axis);
        const Eigen::Matrix<double, 1, 6> mean = c.colwise().mean();
        c.rowwise() -= mean;
        const Eigen::Matrix<double, 1, 6> slope = tau.transpose() * c / stt;
        c -= tau * slope;
        a += c.leftCols<5>().transpose() * c.leftCols<5>();
        g += c.leftCols<5>().transpose() * c.col(5);
        rr += c.col(5).squaredNorm();
        dof += static_cast<int>(k) - 2;
      }
    }
    s = f;
  }
  TrackOffset out;
  const Eigen::FullPivLU<Eigen::Matrix<double, 5, 5>> lu(a);
  if (dof < 1 || !lu.isInvertible()) return out;
  const Eigen::Matrix<double, 5, 1> x = lu.solve(g);
  const double s2 = (rr - x.dot(g)) / dof;
  const double var = lu.inverse()(0, 0);
  out.e = x(0);
  out.information = s2 > 0.0 && var > 0.0 ? 1.0 / (s2 * var) : 0.0;
  return out;
}

// The nominal array with each sensor's mirroring chosen by the counts'
// own rigidity: the least-squares residual of the windows' counts,
// sum_k |(I - H (H^T H)^-1 H^T) c_k|^2, lowered by one sensor's flip at a
// time while a flip halves it (a wrong mirroring leaves
// residuals of the order of the motion's counts, a right one of their
// noise; an array symmetric about an axis fits a global flip as well).
// Positions only: without a heading, a wrongly mirrored sensor would turn
// the array's own rotation, and with it every heading, into noise.
SensorArray rigid_mirroring(const SensorArray& nominal, std::span<const CountsTrack> tracks,
                            std::span<const double> d, std::span<const double> t,
                            const std::vector<std::pair<std::size_t, std::size_t>>& windows) {
  const int n = nominal.size();
  std::vector<Eigen::VectorXd> counts;
  for (const auto& [a, b] : windows) {
    Eigen::VectorXd c(2 * n);
    for (int i = 0; i < n; ++i) {
      const auto u = static_cast<std::size_t>(i);
      c.segment<2>(2 * i) = tracks[u].between(t[a] + d[u], t[b] + d[u]);
    }
    counts.push_back(c);
  }
  const auto residual = [&](const SensorArray& array) {
    const Stack h = stack(array);
    const Eigen::MatrixXd proj =
        Eigen::MatrixXd::Identity(2 * n, 2 * n) - h * (h.transpose() * h).inverse() * h.transpose();
    double sum = 0.0;
    for (const auto& c : counts) sum += (proj * c).squaredNorm();
    return sum;
  };
  // Greedy: one sensor's flip at a time, taken while it halves the residual.
  SensorArray best = nominal;
  double best_residual = residual(nominal);
  for (int round = 0; round < n; ++round) {
    std::optional<SensorArray> next;
    double next_residual = 0.5 * best_residual;
    for (int i = 0; i < n; ++i) {
      std::vector<SensorMount> m(best.mounts().begin(), best.mounts().end());
      m[static_cast<std::size_t>(i)].mirrored = !m[static_cast<std::size_t>(i)].mirrored;
      SensorArray trial(m);
      const double r = residual(trial);
      if (r < next_residual) {
        next_residual = r;
        next = std::move(trial);
      }
    }
    if (!next) break;
    best = *std::move(next);
    best_residual = next_residual;
  }
  return best;
}

}  // namespace

std::variant<PoseReferenceCalibration, PoseReferenceFailure> calibrate_against_poses(
    const SensorArray& nominal, std::span<const CountsTrack> tracks,
    std::span<const double> latency, std::span<const PoseFix> fixes, double reference_latency,
    const PoseReferenceOptions& options) {
  return fit_poses(nominal, tracks, latency, fixes, reference_latency, options, false);
}

std::variant<PoseReferenceCalibration, PoseReferenceFailure> calibrate_against_positions(
    const SensorArray& nominal, std::span<const CountsTrack> tracks,
    std::span<const double> latency, std::span<const PositionFix> fixes, double reference_latency,
    const PoseReferenceOptions& options) {
  const auto fail = [](PoseReferenceError e) { return PoseReferenceFailure{e, std::nullopt}; };
  const int n = nominal.size();
  if (static_cast<int>(tracks.size()) != n || static_cast<int>(latency.size()) != n) {
    return fail(PoseReferenceError::kBadInput);
  }
  std::vector<double> t;
  for (const PositionFix& f : fixes) {
    if (!f.position.allFinite()) return fail(PoseReferenceError::kBadInput);
    t.push_back(f.t);
  }
  if (!valid_fix_times(t)) return fail(PoseReferenceError::kBadInput);
  for (const CountsTrack& tr : tracks) {
    if (tr.empty()) return fail(PoseReferenceError::kTooFewFixes);
  }

  // 0. Coarse: L_r by the robot centre's speed.
  const auto offsets = [&](const std::vector<double>& lat, double lr) {
    std::vector<double> d(lat.size());
    for (std::size_t i = 0; i < lat.size(); ++i) d[i] = lat[i] - lr;
    return d;
  };
  std::vector<double> lat(latency.begin(), latency.end());
  const auto [lo0, hi0] =
      covered_fixes(tracks, fixes, offsets(lat, reference_latency), options.max_offset);
  const std::span<const double> t0(t.data() + lo0, hi0 - lo0);
  const auto coarse_windows = index_windows(t0, options.window);
  if (static_cast<int>(coarse_windows.size()) < kMinWindows) {
    return fail(PoseReferenceError::kTooFewFixes);
  }
  std::vector<double> ref_speed, array_speed, c;
  for (const auto& [a, b] : coarse_windows) {
    ref_speed.push_back((fixes[lo0 + b].position - fixes[lo0 + a].position).norm() /
                        (t0[b] - t0[a]));
  }
  const int lags = static_cast<int>(std::ceil(options.max_offset / kLagStep));
  for (int j = -lags; j <= lags; ++j) {
    const std::vector<double> d = offsets(lat, reference_latency + j * kLagStep);
    array_speed.clear();
    for (const auto& [a, b] : coarse_windows) {
      double sum = 0.0;
      for (int i = 0; i < n; ++i) {
        const auto u = static_cast<std::size_t>(i);
        sum += tracks[u].between(t0[a] + d[u], t0[b] + d[u]).norm() / nominal[i].counts_per_metre();
      }
      array_speed.push_back(sum / (n * (t0[b] - t0[a])));
    }
    c.push_back(pearson_correlation(array_speed, ref_speed));
  }
  const double best_correlation = *std::max_element(c.begin(), c.end());
  const auto peak = correlation_peak(c, kLagStep, options.min_correlation);
  if (!peak) {
    return PoseReferenceFailure{PoseReferenceError::kNoCorrelation, std::nullopt, best_correlation};
  }
  double lr = reference_latency + peak->lag;

  // 1-4, kPositionPasses times; within a pass the heading and the common
  // offset alternate (each needs the other's clock or heading).
  SensorArray array = rigid_mirroring(nominal, tracks, offsets(lat, lr), t0, coarse_windows);
  std::optional<PoseReferenceCalibration> out;
  double lr_before = lr;
  for (int pass = 0; pass < kPositionPasses; ++pass) {
    std::optional<HeadingFit> heading;
    std::vector<PoseFix> poses;
    TrackOffset common;
    for (int step = 0; step < 3; ++step) {
      const std::vector<double> d = offsets(lat, lr);
      const auto [lo, hi] = covered_fixes(tracks, fixes, d, 2.0 * kMaxLatencyStep);
      if (hi < lo + 2) return fail(PoseReferenceError::kTooFewFixes);
      const LeastSquares ls = least_squares(array);
      std::vector<Eigen::Vector3d> z, rate;
      std::vector<Eigen::Vector2d> p;
      for (std::size_t j = lo; j < hi; ++j) {
        p.push_back(fixes[j].position);
        rate.push_back(array_rate(tracks, ls, d, t[j]));
        if (j + 1 < hi) z.push_back(array_displacement(tracks, ls, d, t[j], t[j + 1]));
      }
      std::vector<double> theta;
      const std::span<const double> tj(t.data() + lo, hi - lo);
      heading = fit_heading(tj, p, z, options.window, theta);
      if (!heading) return fail(PoseReferenceError::kTooFewFixes);
      poses.clear();
      for (std::size_t j = 0; j < tj.size(); ++j) poses.push_back({tj[j], Pose2{p[j], theta[j]}});
      common = track_offset(tj, p, z, theta, rate, kTrackSegment);
      // A shift of the array's clock by e is L_r - e (the gauge keeps the
      // L_i); taken when it knows more than the coarse grid does.
      if (common.information * kLagStep * kLagStep >= 1.0) {
        lr -= std::clamp(common.e, -kMaxLatencyStep, kMaxLatencyStep);
      }
    }
    // One mounts / offsets alternation per pass: the passes alternate anyway.
    PoseReferenceOptions once = options;
    once.iterations = 1;
    auto fitted = fit_poses(nominal, tracks, lat, poses, lr, once, true);
    if (auto* f = std::get_if<PoseReferenceFailure>(&fitted)) return *f;
    const double moved = std::abs(lr - lr_before);
    lr_before = lr;
    PoseReferenceCalibration& r = std::get<PoseReferenceCalibration>(fitted);
    heading->yaw_gauge = apply_yaw_gauge(r.exact, nominal);
    array = r.exact.calibrated;
    lat = r.latency;
    lr = r.reference_latency;
    // 1-sigma of L_r: the common offset's and the gauge's (the estimated
    // sensors' mean), as for poses; the coarse grid's when not seen.
    double sum_variance = 0.0;
    int estimated = 0;
    for (std::size_t i = 0; i < r.latency.size(); ++i) {
      if (!r.latency_estimated[i]) continue;
      sum_variance += r.latency_sigma[i] * r.latency_sigma[i];
      ++estimated;
    }
    r.reference_latency_sigma =
        common.information * kLagStep * kLagStep >= 1.0
            ? std::sqrt(1.0 / common.information +
                        (estimated > 0 ? sum_variance / (estimated * estimated) : 0.0))
            : kLagStep;
    r.heading = heading;
    r.coarse_latency = reference_latency + peak->lag;
    r.correlation = best_correlation;
    out = std::move(r);
    if (pass > 0 && moved < kPassTolerance) break;
  }
  return *std::move(out);
}

}  // namespace moa
