// calibration-crb against a pose reference: the exact calibration against
// motion capture (`calib-mocap`: poses at 120 Hz) and a ceiling camera
// (`calib-camera`: positions at 25 Hz), each seed simulated in memory and
// calibrated by the library calls `moa calibrate --method exact --reference
// camera` makes (calibrate_against_poses / calibrate_against_positions,
// default options), compared with the scenario's true robot.
//
// The bound. The Fisher information of the mounts (banded_information:
// calibration_information's, exact.hpp, with the windows' noise correlated
// as it is) at the true mounts, for the true displacement z_k over windows
// of the fixes (consecutive fixes by capture time merged to at least 0.2 s,
// the method's default window), with
//  - count noise s_i^2 (counts^2 per axis and window) measured against the
//    truth: r_ik = c_ik - H_i z_k, c_ik the sensor's counts over the true
//    window on its stamped clock (true latency), H_i = G_i A_i the true
//    mount, z_k = (sum_j R(-theta_j') (p_{j+1} - p_j), theta's change) from
//    the truth sampled at 1 kHz (theta_j' the mean of two rows' headings);
//    s_i^2 = sum r^2 / (2 K) pooled over the seeds, and the lag-1
//    covariance of r between neighbouring windows likewise;
//  - reference noise from the fixes' own: a window's displacement differs
//    from z_k by its end fixes' errors (body frame, isotropic),
//    W = diag(2 sp^2, 2 sp^2, 2 sth^2) (m, m, rad)^2; neighbouring windows
//    share a fix, so their errors correlate (-W/2): a slow signal's errors
//    cancel along the run, which the white model (the method's, and its
//    1-sigma's) does not know; that model's bound is reported beside.
//    Motion capture: sp, sth the scenario's. Ceiling camera: sth = 0, the
//    heading known: the method reconstructs it from the array, which costs
//    more, so the bound is optimistic there; the stamps' jitter is not in
//    it either. The fixes' heading errors times each step's length (about
//    4e-6 m per step at 120 Hz) are left out.
// The latencies are taken as known (the method estimates them too). The
// bound is averaged over the seeds' windows (the camera drops fixes).
//
// Ceiling camera: the robot frame's turn is a gauge (the sensors' mean yaw
// kept as configured), so the truth x is compared as g(x): turned back by
// the circular mean delta of its yaw changes from nominal over the sensors
// whose mirroring is nominal's (tests/tools/compare_calibration.py
// --gauge), and the bound is J CRB J^T, J = dg/dx at the truth (central
// differences).
//
// Per parameter over the seeds: RMSE and bias against the truth, sqrt(CRB),
// efficiency CRB / MSE (MSE / CRB scatters as chi2(K) / K for an efficient
// unbiased estimator), and the run's own 1-sigma (the exact covariance) as
// its RMS over the seeds divided by the RMSE (1: the reported uncertainty is
// right). Latencies relative to the sensors' mean (the gauge of the method),
// the camera's likewise.
#include "calibration_crb_pose.hpp"

#include <fmt/core.h>
#include <fmt/format.h>

#include <Eigen/LU>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <vector>

#include "moa/calibration/exact.hpp"
#include "moa/calibration/pose_reference.hpp"
#include "moa/formats/error.hpp"
#include "moa/sim/scenario.hpp"
#include "moa/sim/simulate.hpp"

namespace moa::experiments {
namespace {

constexpr double kTruthRate = 1000.0;  // rows/s of the truth z_k is integrated from

// The truth's poses (x, y, unwrapped theta) at its rows.
class TruthPath {
 public:
  explicit TruthPath(const std::vector<sim::TruthRecord>& rows) {
    for (std::size_t j = 0; j < rows.size(); ++j) {
      const double th = static_cast<double>(rows[j].pose.theta);
      const double unwrapped = j == 0 ? th : pose_.back()(2) + wrap_angle(th - pose_.back()(2));
      t_.push_back(rows[j].t);
      pose_.emplace_back(static_cast<double>(rows[j].pose.t.x()),
                         static_cast<double>(rows[j].pose.t.y()), unwrapped);
    }
  }
  bool covers(double a, double b) const { return t_.front() <= a && b <= t_.back(); }

  // z over (a, b]: sum over the rows inside of R(-theta') dp and dtheta,
  // the ends interpolated linearly (1 ms rows: 1e-8 m at 0.2 m/s^2).
  Eigen::Vector3d displacement(double a, double b) const {
    std::vector<Eigen::Vector3d> path{at(a)};
    auto j = static_cast<std::size_t>(std::upper_bound(t_.begin(), t_.end(), a) - t_.begin());
    for (; j < t_.size() && t_[j] < b; ++j) path.push_back(pose_[j]);
    path.push_back(at(b));
    Eigen::Vector3d z = Eigen::Vector3d::Zero();
    for (std::size_t k = 1; k < path.size(); ++k) {
      const double mid = 0.5 * (path[k - 1](2) + path[k](2));
      z.head<2>() += rotation(-mid) * (path[k].head<2>() - path[k - 1].head<2>());
    }
    z(2) = path.back()(2) - path.front()(2);
    return z;
  }

 private:
  Eigen::Vector3d at(double time) const {
    const auto hi = static_cast<std::size_t>(
        std::clamp<std::ptrdiff_t>(std::lower_bound(t_.begin(), t_.end(), time) - t_.begin(), 1,
                                   static_cast<std::ptrdiff_t>(t_.size()) - 1));
    const double u = (time - t_[hi - 1]) / (t_[hi] - t_[hi - 1]);
    return (1.0 - u) * pose_[hi - 1] + u * pose_[hi];
  }
  std::vector<double> t_;
  std::vector<Eigen::Vector3d> pose_;
};

// The gauge of calibrate_against_positions applied to parameters x (5N,
// sensor-major): turned back by the circular mean of the yaw changes from
// nominal over the sensors in `same` (mirroring as nominal's).
Eigen::VectorXd gauged(const Eigen::VectorXd& x, const SensorArray& nominal,
                       const std::vector<bool>& same) {
  double s = 0.0, c = 0.0;
  for (int i = 0; i < nominal.size(); ++i) {
    if (!same[static_cast<std::size_t>(i)]) continue;
    const double change =
        wrap_angle(x(kMountParameters * i + 2) - static_cast<double>(nominal[i].yaw));
    s += std::sin(change);
    c += std::cos(change);
  }
  const double delta = std::atan2(s, c);
  Eigen::VectorXd g = x;
  for (int i = 0; i < nominal.size(); ++i) {
    const int k = kMountParameters * i;
    g.segment<2>(k) = rotation(-delta) * x.segment<2>(k);
    g(k + 2) = x(k + 2) - delta;
  }
  return g;
}

Eigen::VectorXd parameters_of(const SensorArray& a) {
  Eigen::VectorXd x(kMountParameters * a.size());
  for (int i = 0; i < a.size(); ++i)
    x.segment<kMountParameters>(kMountParameters * i) = mount_parameters(a[i]);
  return x;
}

// One seed's calibration errors and the data of its bound.
struct SeedRun {
  Eigen::VectorXd error, sigma;                   // 5N: estimate - truth (gauged), reported 1-sigma
  Eigen::VectorXd latency_error, latency_sigma;   // N: relative to the sensors' mean, s
  double camera_error = 0.0, camera_sigma = 0.0;  // s
  bool mirrors = false;
  std::vector<Twist2> twists;  // true, per window
  std::vector<double> dts;
  std::vector<bool> follows;              // the window starts at the previous one's end fix
  std::vector<Eigen::VectorXd> residual;  // 2N counts, c_k - H z_k at the truth
  double seconds = 0.0;                   // wall time of the calibration
};

// Fisher information of the mounts (5N) with the windows' noise as it is:
// stacking every window's counts, c = H z + e with z eliminated through the
// reference w = z + eta (F = G^T S^-1 G, G_k = d(H z_k)/dx as in
// calibration_information), S is block tridiagonal:
//   S_kk = diag(s_i^2 I) + H W H^T,   W = diag(2 sp^2, 2 sp^2, 2 sth^2),
//   S_k,k+1 = diag(c_i I) - H W / 2 H^T   (windows sharing their fix),
// c_i the counts' lag-1 covariance, -W/2 the shared fix's error (+ in one
// window's end, - in the next one's start; body frame, isotropic noise).
// With c_i = 0 and no sharing it is calibration_information's.
Eigen::MatrixXd banded_information(const SensorArray& truth, const SeedRun& run,
                                   const std::vector<double>& var, const std::vector<double>& lag1,
                                   const Eigen::Vector3d& w_diag) {
  const int n = truth.size();
  const int m = 2 * n;
  const auto k_all = static_cast<int>(run.dts.size());
  Eigen::MatrixXd h(m, 3);
  for (int i = 0; i < n; ++i) h.middleRows<2>(2 * i) = truth[i].twist_jacobian().cast<double>();
  Eigen::MatrixXd dcov = Eigen::MatrixXd::Zero(m, m), lcov = Eigen::MatrixXd::Zero(m, m);
  for (int i = 0; i < n; ++i) {
    dcov.block<2, 2>(2 * i, 2 * i) = var[static_cast<std::size_t>(i)] * Eigen::Matrix2d::Identity();
    lcov.block<2, 2>(2 * i, 2 * i) =
        lag1[static_cast<std::size_t>(i)] * Eigen::Matrix2d::Identity();
  }
  const Eigen::MatrixXd diag = dcov + h * w_diag.asDiagonal() * h.transpose();
  const Eigen::MatrixXd off = lcov - 0.5 * h * w_diag.asDiagonal() * h.transpose();
  std::vector<Eigen::Triplet<double>> entries;
  Eigen::MatrixXd g = Eigen::MatrixXd::Zero(m * k_all, kMountParameters * n);
  for (int k = 0; k < k_all; ++k) {
    const auto u = static_cast<std::size_t>(k);
    for (int r = 0; r < m; ++r) {
      for (int c = 0; c < m; ++c) {
        entries.emplace_back(m * k + r, m * k + c, diag(r, c));
        if (k > 0 && run.follows[u]) {
          entries.emplace_back(m * k + r, m * (k - 1) + c, off(r, c));
          entries.emplace_back(m * (k - 1) + c, m * k + r, off(r, c));
        }
      }
    }
    for (int i = 0; i < n; ++i) {
      g.block<2, kMountParameters>(m * k + 2 * i, kMountParameters * i) =
          truth[i].parameter_jacobian(run.twists[u]).cast<double>() * run.dts[u];
    }
  }
  Eigen::SparseMatrix<double> sigma(m * k_all, m * k_all);
  sigma.setFromTriplets(entries.begin(), entries.end());
  const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> chol(sigma);
  if (chol.info() != Eigen::Success)
    throw io::Error("calibration-crb: noise covariance not positive definite");
  const Eigen::MatrixXd solved = chol.solve(g);
  return g.transpose() * solved;
}

double rms(const std::vector<double>& x) {
  double s = 0.0;
  for (const double v : x) s += v * v;
  return std::sqrt(s / static_cast<double>(x.size()));
}
double mean(const std::vector<double>& x) {
  return std::accumulate(x.begin(), x.end(), 0.0) / static_cast<double>(x.size());
}

}  // namespace

void pose_reference_crb(std::string_view scenario_name, const Options& options, int runs,
                        std::string& text, io::JsonWriter& json) {
  sim::Scenario sc = sim::load_scenario(scenario_name);
  // Truth rows only (no random stream draws for them): the logs are those of
  // `moa simulate --scenario NAME --seed K`.
  sc.truth_rate = kTruthRate;
  const bool mocap = sc.camera.mode == sim::CameraMode::kMocap;
  const SensorArray& nominal = sc.nominal.array;
  const SensorArray& truth = sc.truth.array;
  const int n = truth.size();
  const int p_all = kMountParameters * n;
  std::vector<bool> same(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i)
    same[static_cast<std::size_t>(i)] = truth[i].mirrored == nominal[i].mirrored;

  const Eigen::VectorXd x_true = parameters_of(truth);
  const Eigen::VectorXd x_ref = mocap ? x_true : gauged(x_true, nominal, same);
  Eigen::MatrixXd jac = Eigen::MatrixXd::Identity(p_all, p_all);
  if (!mocap) {
    for (int p = 0; p < p_all; ++p) {
      constexpr double h = 1e-6;
      Eigen::VectorXd up = x_true, down = x_true;
      up(p) += h;
      down(p) -= h;
      jac.col(p) = (gauged(up, nominal, same) - gauged(down, nominal, same)) / (2.0 * h);
    }
  }
  std::vector<double> true_latency;
  for (int i = 0; i < n; ++i) true_latency.push_back(static_cast<double>(truth[i].latency));
  const double true_latency_mean = mean(true_latency);
  const double true_camera = sc.truth.camera_latency.value_or(0.0) - true_latency_mean;

  std::vector<SeedRun> seeds;
  std::vector<double> noise_sum(static_cast<std::size_t>(n), 0.0);
  std::vector<double> noise_count(static_cast<std::size_t>(n), 0.0);
  std::vector<double> lag_sum(static_cast<std::size_t>(n), 0.0);
  std::vector<double> lag_count(static_cast<std::size_t>(n), 0.0);
  for (int k = 0; k < runs; ++k) {
    const std::uint64_t seed = options.seed + static_cast<std::uint64_t>(k);
    if (options.progress) {
      options.progress(fmt::format("calibration-crb, {}: run {}/{}", scenario_name, k + 1, runs));
    }
    const sim::SimLog log = sim::simulate(sc, seed);
    std::vector<CountsTrack> tracks(static_cast<std::size_t>(n));
    for (const auto& m : log.mice) {
      tracks[static_cast<std::size_t>(m.sensor)].add(m.t, m.row.counts.cast<double>(),
                                                     m.row.flags != 0);
    }
    std::vector<PoseFix> poses;
    std::vector<PositionFix> positions;
    for (const auto& f : log.camera) {
      positions.push_back({f.t_arrival, f.position});
      if (f.theta) poses.push_back({f.t_arrival, Pose2{f.position, *f.theta}});
    }
    std::vector<double> latency;
    for (int i = 0; i < n; ++i) latency.push_back(static_cast<double>(nominal[i].latency));
    const double camera_latency = sc.nominal.camera_latency.value_or(0.0);
    const auto start = std::chrono::steady_clock::now();
    auto result =
        mocap ? calibrate_against_poses(nominal, tracks, latency, poses, camera_latency)
              : calibrate_against_positions(nominal, tracks, latency, positions, camera_latency);
    SeedRun run;
    run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (const auto* f = std::get_if<PoseReferenceFailure>(&result)) {
      std::string what = describe(f->error);
      if (f->exact_error) what += fmt::format(": {}", describe(*f->exact_error));
      throw io::Error(fmt::format("calibration-crb: {} seed {}: {}", scenario_name, seed, what));
    }
    const auto& pr = std::get<PoseReferenceCalibration>(result);
    const SensorArray& est = pr.exact.calibrated;
    run.error = parameters_of(est) - x_ref;
    run.sigma = pr.exact.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
    run.mirrors = true;
    for (int i = 0; i < n; ++i) {
      run.error(kMountParameters * i + 2) = wrap_angle(run.error(kMountParameters * i + 2));
      run.mirrors = run.mirrors && est[i].mirrored == truth[i].mirrored;
    }
    const double est_mean = mean(pr.latency);
    run.latency_error.resize(n);
    run.latency_sigma.resize(n);
    for (int i = 0; i < n; ++i) {
      const auto u = static_cast<std::size_t>(i);
      run.latency_error(i) = (pr.latency[u] - est_mean) - (true_latency[u] - true_latency_mean);
      run.latency_sigma(i) = pr.latency_sigma[u];
    }
    run.camera_error = (pr.reference_latency - est_mean) - true_camera;
    run.camera_sigma = pr.reference_latency_sigma;

    // The bound's data: windows of the fixes by capture time, true z_k,
    // and the counts' misfit at the true mounts and latencies.
    const TruthPath path(log.truth);
    std::size_t s = 0;
    bool previous_used = false;
    for (std::size_t e = 1; e < log.camera.size(); ++e) {
      const double a = log.camera[s].t, b = log.camera[e].t;
      if (b - a < PoseReferenceOptions{}.window) continue;
      s = e;
      const bool follows = previous_used;
      previous_used = false;
      if (!path.covers(a, b)) continue;
      bool inside = true;
      for (int i = 0; i < n; ++i) {
        const CountsTrack& tr = tracks[static_cast<std::size_t>(i)];
        const double l = true_latency[static_cast<std::size_t>(i)];
        inside = inside && !tr.empty() && tr.front() <= a + l && b + l <= tr.back() &&
                 !tr.flagged(a + l, b + l);
      }
      if (!inside) continue;
      const Eigen::Vector3d z = path.displacement(a, b);
      Eigen::VectorXd res(2 * n);
      for (int i = 0; i < n; ++i) {
        const auto u = static_cast<std::size_t>(i);
        const Eigen::Vector2d r = tracks[u].between(a + true_latency[u], b + true_latency[u]) -
                                  truth[i].twist_jacobian().cast<double>() * z;
        res.segment<2>(2 * i) = r;
        noise_sum[u] += r.squaredNorm();
        noise_count[u] += 2.0;
        if (follows) {
          lag_sum[u] += r.dot(run.residual.back().segment<2>(2 * i));
          lag_count[u] += 2.0;
        }
      }
      run.twists.push_back(Twist2::from_vector(z / (b - a)));
      run.dts.push_back(b - a);
      run.follows.push_back(follows);
      run.residual.push_back(res);
      previous_used = true;
    }
    seeds.push_back(std::move(run));
  }

  CalibrationNoise noise;
  for (int i = 0; i < n; ++i) {
    const auto u = static_cast<std::size_t>(i);
    noise.counts_variance.push_back(noise_sum[u] / noise_count[u]);
  }
  const double sp = sc.camera.noise;
  const double sth = mocap ? sc.camera.heading_noise : 0.0;
  std::vector<double> lag1;
  for (int i = 0; i < n; ++i) {
    const auto u = static_cast<std::size_t>(i);
    lag1.push_back(lag_count[u] > 0.0 ? lag_sum[u] / lag_count[u] : 0.0);
  }
  const Eigen::Vector3d w_diag(2.0 * sp * sp, 2.0 * sp * sp, 2.0 * sth * sth);
  Eigen::MatrixXd crb = Eigen::MatrixXd::Zero(p_all, p_all);
  Eigen::MatrixXd white = Eigen::MatrixXd::Zero(p_all, p_all);
  const std::vector<double> no_lag(static_cast<std::size_t>(n), 0.0);
  double windows = 0.0;
  for (const SeedRun& r : seeds) {
    crb += banded_information(truth, r, noise.counts_variance, lag1, w_diag).inverse() / runs;
    SeedRun alone = r;
    alone.follows.assign(r.follows.size(), false);
    white +=
        banded_information(truth, alone, noise.counts_variance, no_lag, w_diag).inverse() / runs;
    windows += static_cast<double>(r.dts.size()) / runs;
  }
  crb = jac * crb * jac.transpose();
  white = jac * white * jac.transpose();

  // Per parameter over the seeds.
  Eigen::VectorXd rmse(p_all), bias(p_all), bound(p_all), efficiency(p_all), sigma_rms(p_all),
      white_bound(p_all);
  std::vector<std::vector<double>> errors(static_cast<std::size_t>(p_all));
  int mirrors = 0;
  double seconds = 0.0;
  for (const SeedRun& r : seeds) {
    mirrors += r.mirrors ? 1 : 0;
    seconds = std::max(seconds, r.seconds);
  }
  for (int p = 0; p < p_all; ++p) {
    std::vector<double> sg;
    for (const SeedRun& r : seeds) {
      errors[static_cast<std::size_t>(p)].push_back(r.error(p));
      sg.push_back(r.sigma(p));
    }
    rmse(p) = rms(errors[static_cast<std::size_t>(p)]);
    bias(p) = mean(errors[static_cast<std::size_t>(p)]);
    bound(p) = std::sqrt(std::max(crb(p, p), 0.0));
    white_bound(p) = std::sqrt(std::max(white(p, p), 0.0));
    efficiency(p) = crb(p, p) / (rmse(p) * rmse(p));
    sigma_rms(p) = rms(sg);
  }
  std::vector<double> eff(efficiency.data(), efficiency.data() + p_all);
  std::sort(eff.begin(), eff.end());
  const double median = eff[eff.size() / 2];

  const std::array<const char*, kMountParameters> names{"position_x", "position_y", "yaw",
                                                        "scale_x", "scale_y"};
  const std::uint64_t last = options.seed + static_cast<std::uint64_t>(runs) - 1;
  json.begin_object()
      .member("reference", mocap ? "mocap" : "camera")
      .member("scenario", std::string(scenario_name))
      .member("runs", runs)
      .member("first_seed", options.seed)
      .member("last_seed", last)
      .member("gauge", !mocap)
      .member("windows", windows)
      .member("fix_sd", sp)
      .member("heading_sd", sth)
      .key("count_sd")
      .begin_array();
  for (const double v : noise.counts_variance) json.value(std::sqrt(v));
  json.end_array().key("count_lag1_correlation").begin_array();
  for (int i = 0; i < n; ++i)
    json.value(lag1[static_cast<std::size_t>(i)] /
               noise.counts_variance[static_cast<std::size_t>(i)]);
  json.end_array()
      .member("median_efficiency", median)
      .member("mirror_found_runs", mirrors)
      .member("max_calibration_seconds", seconds)
      .key("parameters")
      .begin_array();
  for (int p = 0; p < p_all; ++p) {
    json.begin_object()
        .member("sensor", p / kMountParameters)
        .member("parameter", names[static_cast<std::size_t>(p % kMountParameters)])
        .member("true", x_ref(p))
        .member("rmse", rmse(p))
        .member("bias", bias(p))
        .member("crb_sd", bound(p))
        .member("efficiency", efficiency(p))
        .member("white_crb_sd", white_bound(p))
        .member("sigma_rms", sigma_rms(p))
        .member("sigma_over_rmse", sigma_rms(p) / rmse(p))
        .key("errors")
        .begin_array();
    for (const double e : errors[static_cast<std::size_t>(p)]) json.value(e);
    json.end_array().end_object();
  }
  json.end_array().key("latencies").begin_array();
  const auto latency_row = [&](const char* who, int sensor, const std::vector<double>& e,
                               const std::vector<double>& sg) {
    json.begin_object().member("latency", who);
    if (sensor >= 0) json.member("sensor", sensor);
    json.member("rmse", rms(e))
        .member("bias", mean(e))
        .member("sigma_rms", rms(sg))
        .member("sigma_over_rmse", rms(sg) / rms(e))
        .key("errors")
        .begin_array();
    for (const double v : e) json.value(v);
    json.end_array().end_object();
  };
  std::vector<std::string> latency_lines;
  for (int i = 0; i <= n; ++i) {
    std::vector<double> e, sg;
    for (const SeedRun& r : seeds) {
      e.push_back(i < n ? r.latency_error(i) : r.camera_error);
      sg.push_back(i < n ? r.latency_sigma(i) : r.camera_sigma);
    }
    latency_row(i < n ? "sensor" : "camera", i < n ? i : -1, e, sg);
    latency_lines.push_back(fmt::format("{:<6} {:>11.4f} {:>11.4f} {:>11.4f} {:>10.2f}\n",
                                        i < n ? fmt::format("{}", i) : std::string("camera"),
                                        1e3 * rms(e), 1e3 * mean(e), 1e3 * rms(sg),
                                        rms(sg) / rms(e)));
  }
  json.end_array().end_object();

  std::vector<double> count_sd;
  for (const double v : noise.counts_variance) count_sd.push_back(std::sqrt(v));
  text += fmt::format(
      "\nAgainst {} ({}: {}), seeds {}..{}, {:.0f} windows of 0.2 s\n"
      "per run; fix noise {} m{}; count noise measured against the truth, per sensor\n"
      "{:.3f} counts per axis and window. Bound: the fixes' noise at the window ends,\n"
      "neighbouring windows sharing a fix; latencies known.{}\n"
      "white CRB: the bound with the windows independent (the method's model).\n"
      "1-sigma/RMSE: the run's own 1-sigma (RMS over the seeds) over the RMSE; 1: honest.\n\n",
      mocap ? "motion capture" : "a ceiling camera", scenario_name,
      mocap ? "poses" : "positions only", options.seed, last, windows, sp,
      mocap ? fmt::format(", heading {} rad", sth) : std::string(), fmt::join(count_sd, " "),
      mocap ? ""
            : " Heading known and no\n"
              "jitter (the method reconstructs the heading from the array): optimistic. Gauge:\n"
              "truth and bound turned back by the truth's circular mean yaw change (over the\n"
              "sensors mirrored as nominal).");
  text += fmt::format("{:<6} {:<11} {:>12} {:>11} {:>11} {:>11} {:>10} {:>11} {:>12}\n", "sensor",
                      "parameter", "true", "RMSE", "bias", "sqrt(CRB)", "efficiency", "white CRB",
                      "1-sigma/RMSE");
  for (int p = 0; p < p_all; ++p) {
    text += fmt::format(
        "{:<6} {:<11} {:>12.6f} {:>11.3e} {:>11.2e} {:>11.3e} {:>10.3f} {:>11.3e} {:>12.2f}\n",
        p / kMountParameters, names[static_cast<std::size_t>(p % kMountParameters)], x_ref(p),
        rmse(p), bias(p), bound(p), efficiency(p), white_bound(p), sigma_rms(p) / rmse(p));
  }
  text += fmt::format(
      "\nlatency errors relative to the sensors' mean (ms):\n{:<6} {:>11} {:>11} {:>11} {:>10}\n",
      "who", "RMSE", "bias", "1-sigma", "ratio");
  for (const auto& l : latency_lines) text += l;
  text += fmt::format(
      "\nmedian efficiency {:.3f}; mirroring right in {} of {} runs; calibration at most {:.2f} s "
      "per run\n",
      median, mirrors, runs, seconds);
}

}  // namespace moa::experiments
