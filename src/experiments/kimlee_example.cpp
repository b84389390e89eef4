// moa experiment kimlee-example: Kim & Lee Section V, the position
// calibration example, and Fig. 3's velocity estimates before and after.
//
// The paper's set-up: three ADNS-3080 mice at 1600 cpi aligned with the
// robot axes at radius 0.3 m, first at theta = -pi/6 (eq. (51)); the true
// array is 1.05 x larger (eq. (52)); the robot turns on the spot at 1/3
// rad/s; M = 10 measurements, each the counts of one downsampled packet of
// K = 12 frames at 6400 fps (1.875 ms, eq. (50)). Simulated here in two ways:
// noise-free (real-valued counts: the paper's eq. (53) is reproduced by
// unquantised counts), and with integer counts (quantisation with the
// remainder carried, a random start fraction per sensor and axis), repeated
// --runs times. Fig. 3 is re-run on 500 such quantised samples.
#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include "experiments_list.hpp"
#include "moa/calibration/exact.hpp"
#include "moa/calibration/kimlee.hpp"
#include "moa/core/estimate.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/json.hpp"

namespace moa::experiments {
namespace {

constexpr double kRadius = 0.3;
constexpr int kMeasurements = 10;
constexpr double kRowPeriod = 12.0 / 6400.0;  // K = 12 packets at 6400 fps
constexpr int kFig3Samples = 500;
constexpr std::array<double, 6> kEq51{0.866, -0.500, 0.000, 1.000, -0.866, -0.500};
constexpr std::array<double, 6> kEq52{0.909, -0.525, 0.000, 1.050, -0.909, -0.525};
constexpr std::array<double, 6> kEq53{0.912, -0.526, 0.000, 1.053, -0.912, -0.526};

const Twist2 kSelfRotation{{0.0, 0.0}, 1.0 / 3.0};

SensorArray nominal_array() {
  SensorMount proto;
  proto.cpi = kAdns3080.cpi;
  return regular_polygon(3, kRadius, -std::numbers::pi / 6.0, proto);
}

// Consecutive rows of a constant twist; integer counts (remainder carried
// from a random start fraction) when `rng` is given, else real-valued.
std::vector<ArraySample> rows_of(const SensorArray& truth, int rows, std::mt19937_64* rng) {
  const int n = truth.size();
  std::vector<Eigen::Vector2d> phase(static_cast<std::size_t>(n), Eigen::Vector2d::Zero());
  if (rng) {
    std::uniform_real_distribution<double> u(-0.5, 0.5);
    for (auto& p : phase) p = {u(*rng), u(*rng)};
  }
  std::vector<ArraySample> out;
  for (int k = 1; k <= rows; ++k) {
    ArraySample s;
    s.t = k * kRowPeriod;
    s.dt = kRowPeriod;
    s.size = n;
    for (int i = 0; i < n; ++i) {
      const auto u = static_cast<std::size_t>(i);
      const Eigen::Vector2d per_row = truth[i].counts(kSelfRotation, kRowPeriod);
      const Eigen::Vector2d now = per_row * k + phase[u];
      const Eigen::Vector2d before = per_row * (k - 1) + phase[u];
      s.counts[u] = rng ? Eigen::Vector2d(now.array().round() - before.array().round())
                        : Eigen::Vector2d(now - before);
      s.squal[u] = 255;
    }
    out.push_back(s);
  }
  return out;
}

std::vector<CalibrationSample> measurements(const SensorArray& truth, std::mt19937_64* rng) {
  std::vector<CalibrationSample> out;
  for (const auto& s : rows_of(truth, kMeasurements, rng)) out.push_back({s, kSelfRotation});
  return out;
}

std::array<double, 6> in_units(const SensorArray& a) {
  std::array<double, 6> out{};
  for (int i = 0; i < 3; ++i) {
    out[static_cast<std::size_t>(2 * i)] = a[i].position.x() / kRadius;
    out[static_cast<std::size_t>(2 * i + 1)] = a[i].position.y() / kRadius;
  }
  return out;
}

KimLeeCalibration kimlee(const SensorArray& nominal, const std::vector<CalibrationSample>& m) {
  auto r = calibrate_kimlee(nominal, m);
  if (auto* e = std::get_if<CalibrationError>(&r)) throw io::Error(describe(*e));
  return std::get<KimLeeCalibration>(r);
}

ExactCalibration exact(const SensorArray& nominal, const std::vector<CalibrationSample>& m) {
  auto r = calibrate_exact(nominal, m);
  if (auto* e = std::get_if<CalibrationError>(&r)) throw io::Error(describe(*e));
  return std::get<ExactCalibration>(r);
}

struct Stats {
  std::array<double, 6> mean{};
  std::array<double, 6> sd{};
};

Stats stats(const std::vector<std::array<double, 6>>& xs) {
  Stats s;
  const auto n = static_cast<double>(xs.size());
  for (const auto& x : xs)
    for (std::size_t j = 0; j < 6; ++j) s.mean[j] += x[j] / n;
  for (const auto& x : xs)
    for (std::size_t j = 0; j < 6; ++j) s.sd[j] += (x[j] - s.mean[j]) * (x[j] - s.mean[j]);
  for (auto& v : s.sd) v = n > 1 ? std::sqrt(v / (n - 1)) : 0.0;
  return s;
}

struct Fig3Row {
  std::string positions;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Vector3d sd = Eigen::Vector3d::Zero();
};

Fig3Row velocity_statistics(const std::string& label, const SensorArray& positions,
                            const std::vector<ArraySample>& samples) {
  const auto built = LsEstimator::create(positions, all_sensors(3), kRowPeriod);
  if (const auto* e = std::get_if<GeometryError>(&built)) throw io::Error(describe(*e));
  const auto& est = std::get<LsEstimator>(built);
  Fig3Row row;
  row.positions = label;
  std::vector<Eigen::Vector3d> xs;
  for (const auto& s : samples) xs.push_back(est.estimate(s)->twist.vector());
  for (const auto& x : xs) row.mean += x / static_cast<double>(xs.size());
  for (const auto& x : xs) row.sd += (x - row.mean).cwiseAbs2();
  row.sd = (row.sd / static_cast<double>(xs.size() - 1)).cwiseSqrt();
  return row;
}

std::string fmt6(const std::array<double, 6>& a, int digits = 3) {
  std::string s;
  for (double v : a) s += fmt::format(" {:>8.{}f}", v, digits);
  return s;
}

/// a (in units of 0.3 m) in metres, as a JSON array.
void json6(io::JsonWriter& json, std::string_view name, const std::array<double, 6>& a,
           double unit) {
  json.key(name).begin_array();
  for (double v : a) json.value(v * unit);
  json.end_array();
}

}  // namespace

Result kimlee_example(const Options& options) {
  std::string text;
  const int runs = options.runs > 0 ? options.runs : 200;
  const SensorArray nominal = nominal_array();
  SensorArray truth = nominal;
  for (int i = 0; i < 3; ++i) truth[i].position *= 1.05;

  // Noise-free.
  const auto clean = measurements(truth, nullptr);
  const KimLeeCalibration kl = kimlee(nominal, clean);
  const ExactCalibration ex = exact(nominal, clean);

  // Quantised, repeated.
  std::mt19937_64 rng(options.seed);
  std::vector<std::array<double, 6>> kl_runs, ex_runs;
  std::vector<int> ranks;
  for (int r = 0; r < runs; ++r) {
    const auto m = measurements(truth, &rng);
    const KimLeeCalibration k = kimlee(nominal, m);
    kl_runs.push_back(in_units(k.calibrated));
    ranks.push_back(k.rank);
    ex_runs.push_back(in_units(exact(nominal, m).calibrated));
  }
  const Stats kl_q = stats(kl_runs);
  const Stats ex_q = stats(ex_runs);
  const int rank_min = *std::min_element(ranks.begin(), ranks.end());
  const int rank_max = *std::max_element(ranks.begin(), ranks.end());

  // Fig. 3.
  const auto fig3_samples = rows_of(truth, kFig3Samples, &rng);
  const std::vector<Fig3Row> fig3{
      velocity_statistics("before calibration (eq. 51)", nominal, fig3_samples),
      velocity_statistics("after kimlee (eq. 53)", kl.calibrated, fig3_samples),
      velocity_statistics("after exact", ex.calibrated, fig3_samples),
      velocity_statistics("true positions (eq. 52)", truth, fig3_samples)};

  const auto& kept = ex.sensors[0].estimated;
  io::JsonWriter json;
  json.begin_object().member("experiment", "kimlee-example").member("units", "m");
  json6(json, "nominal_eq51", kEq51, kRadius);
  json6(json, "true_eq52", kEq52, kRadius);
  json6(json, "paper_eq53", kEq53, kRadius);
  json6(json, "kimlee", in_units(kl.calibrated), kRadius);
  json6(json, "exact", in_units(ex.calibrated), kRadius);
  json.member("kimlee_rank", kl.rank).key("kimlee_singular_values").begin_array();
  for (double v : kl.singular_values) json.value(v);
  json.end_array().member("kimlee_threshold", kl.threshold).key("exact_estimated").begin_array();
  for (int k = 0; k < 5; ++k) json.value(static_cast<bool>(kept[static_cast<std::size_t>(k)]));
  json.end_array().key("quantised").begin_object().member("runs", runs);
  json6(json, "kimlee_mean", kl_q.mean, kRadius);
  json6(json, "kimlee_sd", kl_q.sd, kRadius);
  json.member("kimlee_rank_min", rank_min).member("kimlee_rank_max", rank_max);
  json6(json, "exact_mean", ex_q.mean, kRadius);
  json6(json, "exact_sd", ex_q.sd, kRadius);
  json.end_object().member("fig3_samples", kFig3Samples).key("fig3").begin_array();
  for (const auto& f : fig3) {
    json.begin_object().member("positions", f.positions).key("mean").begin_array();
    for (int k = 0; k < 3; ++k) json.value(f.mean(k));
    json.end_array().key("sd").begin_array();
    for (int k = 0; k < 3; ++k) json.value(f.sd(k));
    json.end_array().end_object();
  }
  json.end_array().end_object();

  text += fmt::format(
      "Kim & Lee Section V: N = 3, r = 0.3 m, theta = -pi/6, ADNS-3080 at 1600 cpi, one\n"
      "measurement = 12 packets at 6400 fps ({} ms); true array = 1.05 x nominal;\n"
      "self-rotation at 1/3 rad/s; M = {} measurements.\n\n",
      kRowPeriod * 1e3, kMeasurements);
  text += fmt::format(
      "positions in units of 0.3 m           p1x      p1y      p2x      p2y      p3x      p3y\n");
  text += fmt::format("{:<34}{}\n", "nominal, eq. (51)", fmt6(kEq51));
  text += fmt::format("{:<34}{}\n", "true, eq. (52)", fmt6(kEq52));
  text += fmt::format("{:<34}{}\n", "Kim & Lee's result, eq. (53)", fmt6(kEq53));
  text += fmt::format("{:<34}{}\n", "moa kimlee, noise-free", fmt6(in_units(kl.calibrated), 4));
  text += fmt::format("{:<34}{}\n", "moa exact, noise-free", fmt6(in_units(ex.calibrated), 4));
  text += fmt::format("{:<34}{}\n", fmt::format("moa kimlee, integer counts (mean)"),
                      fmt6(kl_q.mean, 4));
  text += fmt::format("{:<34}{}\n", fmt::format("  sd over {} runs", runs), fmt6(kl_q.sd, 4));
  text += fmt::format("{:<34}{}\n", "moa exact, integer counts (mean)", fmt6(ex_q.mean, 4));
  text += fmt::format("{:<34}{}\n", fmt::format("  sd over {} runs", runs), fmt6(ex_q.sd, 4));
  // Conclusions, computed: which published vector each result is nearest to.
  const auto distance = [](const std::array<double, 6>& a, const std::array<double, 6>& b) {
    double d = 0.0;
    for (std::size_t k = 0; k < 6; ++k) d = std::max(d, std::abs(a[k] - b[k]));
    return d;
  };
  const auto kl_units = in_units(kl.calibrated);
  const auto ex_units = in_units(ex.calibrated);
  const double kl_to_53 = distance(kl_units, kEq53), kl_to_52 = distance(kl_units, kEq52);
  const double ex_to_52 = distance(ex_units, kEq52), ex_to_53 = distance(ex_units, kEq53);
  text += fmt::format(
      "\nkimlee: S is {} x 6, rank {} (threshold {:.3g}); singular values {:.4g}\n"
      "  noise-free result: {:.2g} (units of 0.3 m, max abs) from the paper's eq. (53), {:.2g} "
      "from the\n  truth eq. (52): {}\n  with integer counts the rank was {}..{} over {} runs.\n",
      kMeasurements + 2, kl.rank, kl.threshold, fmt::join(kl.singular_values, " "), kl_to_53,
      kl_to_52,
      kl.rank < 6 && kl_to_53 < kl_to_52
          ? "rank deficient, so the minimum-norm solution reproduces eq. (53), not the truth"
          : (kl_to_52 <= kl_to_53 ? "nearer the truth than eq. (53)" : "nearer eq. (53)"),
      rank_min, rank_max, runs);
  text += fmt::format(
      "exact: estimated flags: position {} {}, yaw {}, scale {} {} (unexcited ones kept at "
      "nominal);\n  result {:.2g} from eq. (52), {:.2g} from eq. (53): {}.\n",
      kept[0], kept[1], kept[2], kept[3], kept[4], ex_to_52, ex_to_53,
      ex_to_52 < ex_to_53 ? "the truth" : "not the truth");
  text += fmt::format("\nFig. 3: velocity estimates over {} samples of integer counts (mean, sd)\n",
                      kFig3Samples);
  text +=
      fmt::format("{:<30} {:>20} {:>20} {:>22}\n", "positions", "vx m/s", "vy m/s", "omega rad/s");
  for (const auto& f : fig3) {
    text += fmt::format("{:<30} {:>9.5f} {:>9.5f}  {:>9.5f} {:>9.5f}  {:>10.6f} {:>9.6f}\n",
                        f.positions, f.mean(0), f.sd(0), f.mean(1), f.sd(1), f.mean(2), f.sd(2));
  }
  // Fig. 3's point, computed: omega after calibration against before and truth.
  const double before = fig3[0].mean(2), after = fig3[1].mean(2), true_w = fig3[3].mean(2);
  text += fmt::format(
      "omega: before / true = {:.4f}, after kimlee / true = {:.4f}, after exact / true = {:.4f}\n"
      "(the paper: after calibration omega moves from the nominal's toward the true one: {}).\n",
      before / true_w, after / true_w, fig3[2].mean(2) / true_w,
      std::abs(after - true_w) < std::abs(before - true_w) ? "it does here" : "it does not here");
  return {text, json.str() + "\n"};
}

}  // namespace moa::experiments
