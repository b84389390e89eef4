// moa experiment calibration-crb: Monte Carlo error of the exact method
// against its Cramer-Rao bound.
//
// A four-sensor robot whose true mounts differ from the nominal ones by up
// to 8 mm, 4 deg and 4 % (one sensor mirrored, unknown to the nominal
// config), driven through 20 s of mixed motion with reference rows at
// 50 Hz. Each run draws new noise: Gaussian count noise of 0.5 count per
// axis and interval, reference (wheel) noise of 1 cm/s on vx, vy and
// 0.05 rad/s on omega. The exact method estimates the noise levels itself.
// Per parameter: the root-mean-square error over the runs, the bound
// sqrt(CRB) (calibration_information at the truth with the true noise), the
// efficiency CRB / MSE (1 for an efficient estimator; MSE / CRB over T runs
// scatters as chi2(T) / T), and for comparison the RMS error of ordinary
// least squares (the reference taken as exact), which the reference noise
// biases.
#include <fmt/core.h>
#include <fmt/format.h>

#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "calibration_crb_pose.hpp"
#include "experiments_list.hpp"
#include "moa/calibration/exact.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/json.hpp"

namespace moa::experiments {
namespace {

constexpr double kDuration = 20.0;
constexpr double kPeriod = 0.02;
constexpr double kCountSd = 0.5;
constexpr double kSpeedSd = 0.01;
constexpr double kRateSd = 0.05;
// Seeds of the pose references (calib-mocap, calib-camera) by default: one
// simulated minute and one calibration each (calibration_crb_pose.cpp).
constexpr int kPoseRuns = 16;

Twist2 mixed(double t) {
  return {{0.2 + 0.15 * std::sin(0.6 * t), 0.2 * std::cos(0.45 * t + 0.3)},
          0.9 * std::sin(0.35 * t + 0.2) + 0.1};
}

SensorArray nominal_array() {
  std::vector<SensorMount> m(4);
  const std::array<double, 4> angle{0.2, 1.8, 3.4, 4.9};
  const std::array<double, 4> yaw{0.3, 1.9, -2.5, -0.7};
  const std::array<double, 4> cpi{800, 1600, 1200, 800};
  for (std::size_t i = 0; i < 4; ++i) {
    m[i].position = 0.1 * Eigen::Vector2d(std::cos(angle[i]), std::sin(angle[i]));
    m[i].yaw = yaw[i];
    m[i].cpi = cpi[i];
  }
  return SensorArray(m);
}

SensorArray true_array(const SensorArray& nominal) {
  SensorArray t = nominal;
  const std::array<Eigen::Vector2d, 4> dp{
      Eigen::Vector2d(0.008, -0.005), Eigen::Vector2d(-0.006, 0.007), Eigen::Vector2d(0.004, 0.008),
      Eigen::Vector2d(-0.008, -0.003)};
  const std::array<double, 4> dyaw_deg{4.0, -3.0, 2.0, -4.0};
  const std::array<Eigen::Vector2d, 4> scale{
      Eigen::Vector2d(1.04, 0.97), Eigen::Vector2d(0.96, 1.03), Eigen::Vector2d(1.02, 1.04),
      Eigen::Vector2d(0.97, 0.96)};
  for (int i = 0; i < 4; ++i) {
    const auto u = static_cast<std::size_t>(i);
    t[i].position += dp[u];
    t[i].yaw += to_radians(dyaw_deg[u]);
    t[i].scale = scale[u];
  }
  t[2].mirrored = true;
  return t;
}

// Twist averaged over each interval (midpoint rule, 8 substeps) and the
// exact counts of `truth` for it (the model is linear in the twist).
std::vector<CalibrationSample> clean_samples(const SensorArray& truth) {
  std::vector<CalibrationSample> out;
  const auto rows = static_cast<int>(std::lround(kDuration / kPeriod));
  for (int k = 1; k <= rows; ++k) {
    const double t0 = (k - 1) * kPeriod;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int s = 0; s < 8; ++s) sum += mixed(t0 + (s + 0.5) * kPeriod / 8.0).vector();
    const Twist2 x = Twist2::from_vector(sum / 8.0);
    CalibrationSample c;
    c.reference = x;
    c.mice.t = k * kPeriod;
    c.mice.dt = kPeriod;
    c.mice.size = truth.size();
    for (int i = 0; i < truth.size(); ++i) {
      const auto u = static_cast<std::size_t>(i);
      c.mice.counts[u] = truth[i].counts(x, kPeriod);
      c.mice.squal[u] = 255;
    }
    out.push_back(c);
  }
  return out;
}

MountVector difference(const SensorMount& a, const SensorMount& b) {
  MountVector d = mount_parameters(a) - mount_parameters(b);
  d(2) = wrap_angle(d(2));
  return d;
}

}  // namespace

Result calibration_crb(const Options& options) {
  std::string text;
  const int runs = options.runs > 0 ? options.runs : 50;
  const SensorArray nominal = nominal_array();
  const SensorArray truth = true_array(nominal);
  const auto clean = clean_samples(truth);
  const int n = truth.size();

  CalibrationNoise noise;
  noise.counts_variance.assign(static_cast<std::size_t>(n), kCountSd * kCountSd);
  noise.reference_covariance =
      Eigen::Vector3d(kSpeedSd * kSpeedSd, kSpeedSd * kSpeedSd, kRateSd * kRateSd).asDiagonal();
  std::vector<Twist2> twists;
  std::vector<double> dts;
  for (const auto& s : clean) {
    twists.push_back(s.reference);
    dts.push_back(s.mice.dt);
  }
  const Eigen::MatrixXd crb = calibration_information(truth, twists, dts, noise).inverse();

  std::mt19937_64 rng(options.seed);
  std::normal_distribution<double> g(0.0, 1.0);
  const int p_all = kMountParameters * n;
  Eigen::VectorXd sq = Eigen::VectorXd::Zero(p_all), bias = Eigen::VectorXd::Zero(p_all),
                  sq_ols = Eigen::VectorXd::Zero(p_all);
  int mirrors_found = 0;
  ExactOptions ols;
  ols.errors_in_variables = false;
  for (int r = 0; r < runs; ++r) {
    auto samples = clean;
    for (auto& s : samples) {
      for (int i = 0; i < n; ++i) {
        s.mice.counts[static_cast<std::size_t>(i)] += kCountSd * Eigen::Vector2d(g(rng), g(rng));
      }
      s.reference.v += kSpeedSd * Eigen::Vector2d(g(rng), g(rng));
      s.reference.omega += kRateSd * g(rng);
    }
    const auto eiv = calibrate_exact(nominal, samples);
    const auto plain = calibrate_exact(nominal, samples, ols);
    if (const auto* e = std::get_if<CalibrationError>(&eiv)) throw io::Error(describe(*e));
    if (const auto* e = std::get_if<CalibrationError>(&plain)) throw io::Error(describe(*e));
    const auto& a = std::get<ExactCalibration>(eiv).calibrated;
    const auto& b = std::get<ExactCalibration>(plain).calibrated;
    bool all_mirrors = true;
    for (int i = 0; i < n; ++i) {
      const MountVector d = difference(a[i], truth[i]);
      sq.segment<kMountParameters>(kMountParameters * i) += d.cwiseAbs2();
      bias.segment<kMountParameters>(kMountParameters * i) += d;
      sq_ols.segment<kMountParameters>(kMountParameters * i) +=
          difference(b[i], truth[i]).cwiseAbs2();
      all_mirrors = all_mirrors && a[i].mirrored == truth[i].mirrored;
    }
    mirrors_found += all_mirrors ? 1 : 0;
  }
  const Eigen::VectorXd rmse = (sq / runs).cwiseSqrt();
  const Eigen::VectorXd rmse_ols = (sq_ols / runs).cwiseSqrt();
  bias /= runs;
  Eigen::VectorXd bound(p_all), efficiency(p_all);
  for (int p = 0; p < p_all; ++p) {
    bound(p) = std::sqrt(crb(p, p));
    efficiency(p) = crb(p, p) / (sq(p) / runs);
  }
  std::vector<double> eff(efficiency.data(), efficiency.data() + p_all);
  std::sort(eff.begin(), eff.end());
  const double median = eff[eff.size() / 2];

  const std::array<const char*, kMountParameters> names{"position_x", "position_y", "yaw",
                                                        "scale_x", "scale_y"};
  io::JsonWriter json;
  json.begin_object()
      .member("experiment", "calibration-crb")
      .member("runs", runs)
      .member("samples", static_cast<std::uint64_t>(clean.size()))
      .member("count_sd", kCountSd)
      .key("reference_sd")
      .begin_array()
      .value(kSpeedSd)
      .value(kSpeedSd)
      .value(kRateSd)
      .end_array()
      .member("median_efficiency", median)
      .member("mirror_found_runs", mirrors_found)
      .key("parameters")
      .begin_array();
  for (int p = 0; p < p_all; ++p) {
    json.begin_object()
        .member("sensor", p / kMountParameters)
        .member("parameter", names[static_cast<std::size_t>(p % kMountParameters)])
        .member("true", mount_parameters(truth[p / kMountParameters])(p % kMountParameters))
        .member("rmse", rmse(p))
        .member("bias", bias(p))
        .member("crb_sd", bound(p))
        .member("efficiency", efficiency(p))
        .member("rmse_ols", rmse_ols(p))
        .end_object();
  }
  json.end_array();
  std::string pose_text;
  json.key("references").begin_array();
  const int pose_runs = options.runs > 0 ? options.runs : kPoseRuns;
  for (const char* scenario : {"calib-mocap", "calib-camera"}) {
    pose_reference_crb(scenario, options, pose_runs, pose_text, json);
  }
  json.end_array().end_object();
  text += fmt::format(
      "Exact calibration against its Cramer-Rao bound: 4 sensors, errors up to 8 mm, 4 deg, 4 %,\n"
      "sensor 2 mirrored (not in the nominal config); {} s of mixed motion, {} reference\n"
      "intervals; noise: {} count per axis, reference {} m/s and {} rad/s; {} runs.\n"
      "units: m, rad, 1. efficiency = CRB / MSE (MSE / CRB scatters as chi2({}) / {}).\n\n",
      kDuration, clean.size(), kCountSd, kSpeedSd, kRateSd, runs, runs, runs);
  text += fmt::format("{:<6} {:<11} {:>12} {:>11} {:>11} {:>11} {:>10} {:>11}\n", "sensor",
                      "parameter", "true", "RMSE", "bias", "sqrt(CRB)", "efficiency", "RMSE OLS");
  for (int p = 0; p < p_all; ++p) {
    text +=
        fmt::format("{:<6} {:<11} {:>12.6f} {:>11.3e} {:>11.2e} {:>11.3e} {:>10.3f} {:>11.3e}\n",
                    p / kMountParameters, names[static_cast<std::size_t>(p % kMountParameters)],
                    mount_parameters(truth[p / kMountParameters])(p % kMountParameters), rmse(p),
                    bias(p), bound(p), efficiency(p), rmse_ols(p));
  }
  text += fmt::format("\nmedian efficiency {:.3f}; mirroring right in {} of {} runs\n", median,
                      mirrors_found, runs);
  text += pose_text;
  return {text, json.str() + "\n"};
}

}  // namespace moa::experiments
