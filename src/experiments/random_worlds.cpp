// `moa experiment random --family F --seeds A-B`: the estimators on random
// worlds (sim/random_world.hpp), each beside two yardsticks on the same log:
//   selection  the oracle estimator with robot.yaml: it knows which sensor
//              is faulty when (faults.csv) and nothing else;
//   oracle     the same with robot.true.yaml: it knows the true mounts,
//              scales, latencies and the gyro's calibration as well.
// Both are least squares over the sensors without a fault in the epoch
// (wheels when fewer than two are left). The oracle also fuses the gyro with
// its true scale and initial bias, except where it was faulty (stuck,
// saturated, after a bias step: imu.csv's `faults`); selection uses no gyro,
// since the one robot.yaml configures (scale 1, bias 0) is off by up to 3 %
// and 0.05 rad/s and would be no yardstick. Plain least squares and the
// wheels alone are the floor.
//
// Per seed: the max translation (m) and heading (rad) error of each method,
// as `moa evaluate` computes them, and each method's ratio to selection and
// to the oracle (denominators at least 1 mm and 0.01 deg, so that a world
// where the yardstick is all but exact does not divide by nothing). A
// failure of an estimator under test (default, self_calibrate, no_imu) is an
// error (the message is kept), a non-finite figure, or a ratio to selection
// over 5. Worlds that say what their data cannot show (Scenario::unobservable)
// are counted apart and left out of the distributions.
//
// Consistency of the default (the consensus): per epoch the normalised
// estimation error squared of the twist, e' P^-1 e, e the estimate minus
// the true twist averaged over the epoch (the SE(2) logarithm of the truth's
// poses at its ends, interpolated, over its length), P the estimate's
// covariance; its mean over a world's epochs is 3 for a consistent filter.
// And a state the data cannot see: during the initial rest (before the
// first motion) the gyro's scale must stay at its prior, measured as the
// largest |scale(t) - scale(t0)| over the prior's sd. At the end of the run
// the gyro's scale, and its bias where it neither walks nor steps, against
// the truth: ((x - x_true) / sd)^2, 1 on average for a consistent filter.
#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <mutex>
#include <numbers>
#include <optional>
#include <thread>
#include <vector>

#include <Eigen/Cholesky>

#include "experiments_list.hpp"
#include "moa/analysis/evaluate.hpp"
#include "moa/experiments/simulated_run.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/json.hpp"
#include "moa/formats/log.hpp"
#include "moa/runs/evaluate.hpp"
#include "moa/runs/odometry_run.hpp"
#include "moa/sim/log_writer.hpp"
#include "moa/sim/random_world.hpp"
#include "moa/web/report.hpp"

namespace moa::experiments {
namespace {

namespace fs = std::filesystem;

enum MethodIndex : std::size_t {
  kDefault,
  kSelfCalibrate,
  kNoImu,
  kSelection,
  kOracle,
  kLs,
  kWheels,
  kMethods
};
constexpr const char* kNames[kMethods] = {
    "default", "self_calibrate", "no_imu", "selection", "oracle", "ls", "wheels"};
constexpr bool kUnderTest[kMethods] = {true, true, true, false, false, false, false};
constexpr double kMinTranslation = 0.001;                      // m
constexpr double kMinHeading = 0.01 * std::numbers::pi / 180;  // rad
constexpr double kFailureRatio = 5.0;

struct Figures {
  bool run = false;                         ///< applicable to the world and run
  std::string error;                        ///< refused or failed: why
  double translation = 0.0, heading = 0.0;  ///< m, rad (max over the run)
};

struct SeedResult {
  std::uint64_t seed = 0;
  std::string family, world;
  std::vector<std::string> unobservable;
  std::array<Figures, kMethods> m;
  double nees = std::nan("");        ///< mean twist NEES of the default over the epochs
  double rest_scale = std::nan("");  ///< max |scale - scale0| / sd0 in the initial rest
  /// The gyro's calibration at the end against the truth, ((x - x_true) / sd)^2:
  /// its scale, and its bias where the bias neither walks nor steps.
  double scale_nees = std::nan(""), bias_nees = std::nan("");
  /// The gyro's latency learnt at the end against the truth, the same way.
  double latency_nees = std::nan("");
  std::string failure;  ///< of the estimators under test, "" if none
};

Method options_of(MethodIndex k) {
  switch (k) {
    case kSelfCalibrate:
      return method_of(kNames[k], EstimatorKind::kConsensus, true);
    case kNoImu: {
      Method m = method_of(kNames[k], EstimatorKind::kConsensus);
      m.options.use_imu = false;
      return m;
    }
    case kSelection: {
      // The configured gyro's bias and scale are what robot.yaml believes
      // (bias 0, scale 1), off by up to 0.05 rad/s: no yardstick; it is left out.
      Method m = method_of(kNames[k], EstimatorKind::kOracle);
      m.options.use_imu = false;
      return m;
    }
    case kOracle:
      return method_of(kNames[k], EstimatorKind::kOracle);
    case kLs:
      return method_of(kNames[k], EstimatorKind::kLs);
    case kWheels:
      return method_of(kNames[k], EstimatorKind::kWheels);
    default:
      return method_of(kNames[k], EstimatorKind::kConsensus);
  }
}

std::string command_of(std::uint64_t seed, const std::string& family) {
  return fmt::format(
      "moa simulate --random {} --family {} --out $OUT && moa odometry --config "
      "$OUT/robot.yaml --log $OUT --out $OUT/odometry.csv && moa evaluate --truth "
      "$OUT/truth.csv --odometry $OUT/odometry.csv",
      seed, family);
}

// The true twist averaged over (t - dt, t]: log(T(t - dt)^-1 T(t)) / dt.
std::optional<Twist2> true_twist(std::span<const StampedPose> truth, double t, double dt) {
  const auto a = interpolate(truth, t - dt), b = interpolate(truth, t);
  if (!a || !b) return std::nullopt;
  return twist_between(*a, *b, static_cast<real>(dt));
}

void consistency(const sim::RandomWorld& world, const fs::path& dir,
                 std::span<const StampedPose> truth, SeedResult& r) {
  const io::RobotConfig config = io::read_config(dir / "robot.yaml");
  const OdometryOptions options = options_of(kDefault).options;
  // The first moment the truth moves: the initial rest ends there.
  double moved = truth.back().t;
  for (std::size_t i = 1; i < truth.size(); ++i) {
    const auto& p = truth[i].pose;
    if (std::hypot(p.t.x(), p.t.y()) > 1e-6 || std::abs(p.theta) > 1e-6) {
      moved = truth[i - 1].t;
      break;
    }
  }
  double sum = 0.0;
  std::size_t epochs = 0;
  std::optional<double> scale0, sd0;
  double rest = 0.0;
  const GyroModel* last_gyro = nullptr;
  double scale_end = 0.0, scale_sd = 0.0, bias_end = 0.0, bias_sd = 0.0, latency_end = 0.0,
         latency_sd = 0.0;
  const double dt = 1.0 / options.rate;
  io::run_odometry(config, (dir / "robot.yaml").string(), io::resolve_log(dir), options,
                   [&](const OdometryStep& step) {
                     if (step.gyro != nullptr) {
                       last_gyro = step.gyro;
                       scale_end = step.gyro->scale();
                       scale_sd = step.gyro->scale_sd();
                       bias_end = step.gyro->bias();
                       bias_sd = step.gyro->bias_sd();
                       latency_end = step.gyro->latency();
                       latency_sd = step.gyro->latency_sd();
                     }
                     if (step.gyro != nullptr && step.t() <= moved) {
                       if (!scale0) {
                         scale0 = step.gyro->scale();
                         sd0 = step.gyro->scale_sd();
                       } else if (*sd0 > 0.0) {
                         rest = std::max(rest, std::abs(step.gyro->scale() - *scale0) / *sd0);
                       }
                     }
                     const auto x = true_twist(truth, step.t(), dt);
                     if (!x) return;
                     const Vec3 e = step.estimate.estimate.twist.vector() - x->vector();
                     const Mat3& p = step.estimate.estimate.covariance;
                     const Eigen::LDLT<Mat3> ldlt(p);
                     if (ldlt.info() != Eigen::Success || !(p.trace() > 0.0)) return;
                     const double q = e.dot(ldlt.solve(e));
                     if (!std::isfinite(q)) return;
                     sum += q;
                     ++epochs;
                   });
  if (epochs > 0) r.nees = sum / static_cast<double>(epochs);
  if (scale0) r.rest_scale = rest;
  const sim::GyroSpec& g = world.scenario.imu;
  if (last_gyro != nullptr && scale_sd > 0.0) {
    r.scale_nees = std::pow((scale_end - g.scale) / scale_sd, 2);
    if (latency_sd > 0.0) r.latency_nees = std::pow((latency_end - g.latency) / latency_sd, 2);
    const bool steps = std::any_of(g.faults.begin(), g.faults.end(), [](const auto& f) {
      return f.kind == sim::GyroFault::kBiasStep;
    });
    if (g.bias_walk == 0.0 && !steps && bias_sd > 0.0) {
      r.bias_nees = std::pow((bias_end - g.bias) / bias_sd, 2);
    }
  }
}

SeedResult run_seed(std::uint64_t seed, const std::string& family, const fs::path& scratch) {
  SeedResult r;
  r.seed = seed;
  const sim::RandomWorld world = sim::random_scenario(seed, family);
  r.family = world.family;
  r.world = world.summary;
  r.unobservable = world.scenario.unobservable;
  const fs::path dir = scratch / fmt::format("random-{}-{}", family, seed);
  sim::write_log(world.scenario, seed, dir, {}, world.yaml);
  std::vector<StampedPose> truth;
  for (const auto& row : io::read_all<io::TruthRow>(dir / "truth.csv")) {
    truth.push_back({row.t, row.pose});
  }
  const bool has_wheels = fs::exists(dir / "wheels.csv");
  const bool has_gyro = world.scenario.imu.enabled;
  const int sensors = world.scenario.nominal.array.size();
  for (std::size_t k = 0; k < kMethods; ++k) {
    Figures& f = r.m[k];
    // Not applicable: the wheels alone without wheels; without a gyro
    // --no-imu is the default; one sensor has no rotation without a gyro.
    if (k == kWheels && !has_wheels) continue;
    if (k == kNoImu && !has_gyro) continue;
    if ((k == kNoImu || k == kLs || k == kSelection || k == kOracle) && sensors < 2) continue;
    f.run = true;
    const Method method = options_of(static_cast<MethodIndex>(k));
    const fs::path config = dir / (k == kOracle ? "robot.true.yaml" : "robot.yaml");
    const fs::path out = dir / fmt::format("odometry-{}.csv", kNames[k]);
    try {
      io::write_odometry(io::read_config(config), config.string(), io::resolve_log(dir),
                         method.options, out);
      const TrajectoryError e = io::evaluate_files(dir / "truth.csv", out);
      f.translation = e.max_translation;
      f.heading = e.max_heading;
      if (!std::isfinite(f.translation) || !std::isfinite(f.heading)) f.error = "not finite";
    } catch (const std::exception& e) {
      f.error = e.what();
    }
    std::error_code ignored;
    fs::remove(out, ignored);
  }
  try {
    consistency(world, dir, truth, r);
  } catch (const std::exception&) {
    // The default's own failure is recorded above.
  }
  const Figures& sel = r.m[kSelection];
  for (std::size_t k = 0; k < kMethods; ++k) {
    const Figures& f = r.m[k];
    if (!kUnderTest[k] || !f.run) continue;
    if (!f.error.empty()) {
      r.failure += fmt::format("{}{}: {}", r.failure.empty() ? "" : "; ", kNames[k], f.error);
    } else if (sel.run && sel.error.empty() && r.unobservable.empty()) {
      const double a = f.translation / std::max(sel.translation, kMinTranslation);
      const double b = f.heading / std::max(sel.heading, kMinHeading);
      if (a > kFailureRatio || b > kFailureRatio) {
        r.failure += fmt::format("{}{}: {:.1f}x selection in translation, {:.1f}x in heading",
                                 r.failure.empty() ? "" : "; ", kNames[k], a, b);
      }
    }
  }
  std::error_code ignored;
  fs::remove_all(dir, ignored);
  return r;
}

struct Quantiles {
  double median = std::nan(""), p90 = std::nan(""), max = std::nan("");
  std::size_t n = 0;
};
Quantiles quantiles(std::vector<double> v) {
  Quantiles q;
  q.n = v.size();
  if (v.empty()) return q;
  std::sort(v.begin(), v.end());
  // The nearest rank: the smallest value with at least p of the values at or below it.
  const auto rank = [&](double p) {
    const auto i = static_cast<std::size_t>(std::ceil(p * static_cast<double>(v.size())));
    return v[std::clamp<std::size_t>(i, 1, v.size()) - 1];
  };
  q.median = rank(0.5);
  q.p90 = rank(0.9);
  q.max = v.back();
  return q;
}

struct Ratios {
  Quantiles translation, heading;
};
Ratios ratios(const std::vector<SeedResult>& results, std::size_t k, std::size_t against) {
  std::vector<double> a, b;
  for (const auto& r : results) {
    const Figures& f = r.m[k];
    const Figures& y = r.m[against];
    if (!r.unobservable.empty() || !f.run || !y.run || !f.error.empty() || !y.error.empty()) {
      continue;
    }
    a.push_back(f.translation / std::max(y.translation, kMinTranslation));
    b.push_back(f.heading / std::max(y.heading, kMinHeading));
  }
  return {quantiles(a), quantiles(b)};
}

std::string cell(const Quantiles& q) {
  if (q.n == 0) return "-";
  return fmt::format("{:.2f} / {:.2f} / {:.2f}", q.median, q.p90, q.max);
}

void write_quantiles(io::JsonWriter& j, const Quantiles& q) {
  j.begin_object();
  const auto value = [&](const char* name, double x) {
    if (std::isfinite(x)) {
      j.member(name, x);
    } else {
      j.key(name).null();
    }
  };
  value("median", q.median);
  value("p90", q.p90);
  value("max", q.max);
  j.member("n", static_cast<std::uint64_t>(q.n)).end_object();
}

}  // namespace

void write_random_report(std::uint64_t seed, const std::string& family, const fs::path& out) {
  const sim::RandomWorld world = sim::random_scenario(seed, family);
  const ScratchDirectory dir("moa-random-report");
  const fs::path log = dir.path() / "log";
  sim::write_log(world.scenario, seed, log, {}, world.yaml);
  const fs::path odometry = dir.path() / "odometry.csv";
  const fs::path config = log / "robot.yaml";
  io::write_odometry(io::read_config(config), config.string(), io::resolve_log(log),
                     options_of(kDefault).options, odometry);
  io::ReportInputs inputs;
  inputs.config = config;
  inputs.log = log;
  inputs.odometry = odometry;
  inputs.truth = log / "truth.csv";
  inputs.title = fmt::format("moa experiment random: seed {}, family {}", seed, world.family);
  inputs.note = fmt::format(
      "The world: {}. The run of `moa simulate --random {} --family {}`, dead reckoning as `moa "
      "odometry` (the default estimator); its files were temporary.",
      world.summary, seed, family);
  io::write_report(inputs, out);
}

Result random_worlds(const Options& options) {
  const std::string family = options.family.empty() ? "any" : options.family;
  (void)sim::random_scenario(options.seed, family);  // an unknown family fails here, at once
  const std::uint64_t first = options.seed;
  const std::uint64_t count = options.runs > 0 ? static_cast<std::uint64_t>(options.runs) : 20;
  const ScratchDirectory scratch("moa-random");
  std::vector<SeedResult> results(count);
  std::atomic<std::uint64_t> next{0};
  std::atomic<std::uint64_t> done{0};
  std::mutex progress_mutex;
  const auto start = std::chrono::steady_clock::now();
  const auto worker = [&] {
    for (std::uint64_t i = next++; i < count; i = next++) {
      try {
        results[i] = run_seed(first + i, family, scratch.path());
      } catch (const std::exception& e) {
        results[i].seed = first + i;
        results[i].family = family;
        results[i].failure = fmt::format("the world: {}", e.what());
      }
      const std::uint64_t n = ++done;
      if (options.progress) {
        const double minutes =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / 60;
        const std::lock_guard lock(progress_mutex);
        options.progress(fmt::format("random {}: seed {} of {} ({:.1f} seeds per minute)", family,
                                     n, count, static_cast<double>(n) / std::max(minutes, 1e-9)));
      }
    }
  };
  const unsigned threads = std::max(
      1u, std::min<unsigned>(std::thread::hardware_concurrency(), static_cast<unsigned>(count)));
  std::vector<std::thread> pool;
  for (unsigned t = 0; t < threads; ++t) pool.emplace_back(worker);
  for (auto& t : pool) t.join();
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double per_minute = static_cast<double>(count) / std::max(seconds / 60.0, 1e-9);

  std::size_t unobservable = 0;
  for (const auto& r : results) unobservable += r.unobservable.empty() ? 0 : 1;
  std::array<std::size_t, kMethods> failures{};
  for (const auto& r : results) {
    for (std::size_t k = 0; k < kMethods; ++k) {
      if (r.failure.find(std::string(kNames[k]) + ":") != std::string::npos) ++failures[k];
    }
  }
  // The worst seeds: the default's larger ratio to selection, observable worlds first.
  std::vector<const SeedResult*> order;
  for (const auto& r : results) order.push_back(&r);
  const auto badness = [](const SeedResult& r) {
    const Figures& f = r.m[kDefault];
    const Figures& s = r.m[kSelection];
    if (!f.error.empty() || r.failure.starts_with("the world")) return 1e300;
    if (!s.run || !s.error.empty()) return 0.0;
    return std::max(f.translation / std::max(s.translation, kMinTranslation),
                    f.heading / std::max(s.heading, kMinHeading));
  };
  std::stable_sort(order.begin(), order.end(), [&](const SeedResult* a, const SeedResult* b) {
    if (a->unobservable.empty() != b->unobservable.empty()) return a->unobservable.empty();
    return badness(*a) > badness(*b);
  });
  // Only worlds with a ratio to selection (two sensors or more, selection ran) or a failure.
  std::erase_if(order, [](const SeedResult* r) {
    const Figures& s = r->m[kSelection];
    return r->failure.empty() && (!s.run || !s.error.empty());
  });
  const std::size_t worst = std::min<std::size_t>(5, order.size());
  std::size_t without = 0;  // worlds with no ratio to selection: one sensor
  for (const auto& r : results) without += r.m[kSelection].run ? 0 : 1;
  std::vector<double> nees, rest, scale_nees, bias_nees, latency_nees;
  for (const auto& r : results) {
    if (std::isfinite(r.nees)) nees.push_back(r.nees);
    if (std::isfinite(r.rest_scale)) rest.push_back(r.rest_scale);
    if (std::isfinite(r.scale_nees)) scale_nees.push_back(r.scale_nees);
    if (std::isfinite(r.bias_nees)) bias_nees.push_back(r.bias_nees);
    if (std::isfinite(r.latency_nees)) latency_nees.push_back(r.latency_nees);
  }
  const Quantiles nees_q = quantiles(nees), rest_q = quantiles(rest);
  const Quantiles scale_q = quantiles(scale_nees), bias_q = quantiles(bias_nees),
                  latency_q = quantiles(latency_nees);
  const auto mean = [](const std::vector<double>& v) {
    double sum = 0.0;
    for (const double x : v) sum += x;
    return v.empty() ? std::nan("") : sum / static_cast<double>(v.size());
  };

  // ---------------------------------------------------------------- text
  std::string t;
  auto out = std::back_inserter(t);
  fmt::format_to(out,
                 "Random worlds, family {}, seeds {}-{} ({} world{}, {} with something no "
                 "estimator can see and {} with one sensor, which have no yardstick, counted "
                 "apart); {:.1f} seeds per minute on {} thread{}.\n"
                 "Tune on seeds 1-9999, report from 10001.\n\n",
                 family, first, first + count - 1, count, count == 1 ? "" : "s", unobservable,
                 without, per_minute, threads, threads == 1 ? "" : "s");
  t += "Ratio of each method's max error to selection's and to the oracle's (median / p90 / "
       "max over the observable worlds):\n\n";
  fmt::format_to(out,
                 "| method | vs selection, translation | heading | vs oracle, translation | "
                 "heading | failures |\n|---|---|---|---|---|---|\n");
  for (std::size_t k = 0; k < kMethods; ++k) {
    const Ratios s = ratios(results, k, kSelection), o = ratios(results, k, kOracle);
    fmt::format_to(out, "| {} | {} | {} | {} | {} | {} |\n", kNames[k], cell(s.translation),
                   cell(s.heading), cell(o.translation), cell(o.heading),
                   kUnderTest[k] ? fmt::format("{}", failures[k]) : std::string("-"));
  }
  fmt::format_to(out,
                 "\nConsistency of the default: mean twist NEES per world (3 if consistent) "
                 "median {:.2f}, p90 {:.2f}, max {:.2f} over {} worlds; the gyro's scale in the "
                 "initial rest: its largest move per world, in prior sds, median {:.2f}, max "
                 "{:.2f} over {} worlds with a gyro.\n",
                 nees_q.median, nees_q.p90, nees_q.max, nees_q.n, rest_q.median, rest_q.max,
                 rest_q.n);
  fmt::format_to(out,
                 "The gyro's calibration at the end against the truth, ((x - x_true) / sd)^2 "
                 "(mean 1 if consistent): scale mean {:.2f}, median {:.2f}, max {:.1f} over {} "
                 "worlds; bias (no walk, no step) mean {:.2f}, median {:.2f}, max {:.1f} over {}; "
                 "latency mean {:.2f}, median {:.2f}, max {:.1f} over {}.\n",
                 mean(scale_nees), scale_q.median, scale_q.max, scale_q.n, mean(bias_nees),
                 bias_q.median, bias_q.max, bias_q.n, mean(latency_nees), latency_q.median,
                 latency_q.max, latency_q.n);
  t += "\nFailures (an error, a non-finite figure, or over 5x selection):\n";
  std::size_t listed = 0;
  for (const auto& r : results) {
    if (r.failure.empty()) continue;
    fmt::format_to(out, "  seed {}: {}\n", r.seed, r.failure);
    ++listed;
  }
  if (listed == 0) t += "  none\n";
  t += "\nThe five worst seeds (the default's larger ratio to selection):\n";
  for (std::size_t i = 0; i < worst; ++i) {
    const SeedResult& r = *order[i];
    const Figures& f = r.m[kDefault];
    const Figures& s = r.m[kSelection];
    fmt::format_to(
        out, "  seed {} ({}): default {:.1f} mm / {:.2f} deg, selection {}{}\n    {}\n    {}\n",
        r.seed, r.family, 1000 * f.translation, f.heading * 180 / std::numbers::pi,
        s.run && s.error.empty() ? fmt::format("{:.1f} mm / {:.2f} deg", 1000 * s.translation,
                                               s.heading * 180 / std::numbers::pi)
                                 : std::string("-"),
        r.unobservable.empty() ? "" : " (unobservable)", r.world, command_of(r.seed, r.family));
  }

  // ---------------------------------------------------------------- JSON
  io::JsonWriter j;
  j.begin_object()
      .member("experiment", "random")
      .member("family", family)
      .key("seeds")
      .begin_array()
      .value(first)
      .value(first + count - 1)
      .end_array()
      .member("seeds_per_minute", per_minute)
      .key("estimators")
      .begin_object();
  for (std::size_t k = 0; k < kMethods; ++k) {
    const Ratios s = ratios(results, k, kSelection), o = ratios(results, k, kOracle);
    j.key(kNames[k]).begin_object().key("vs_selection").begin_object().key("translation");
    write_quantiles(j, s.translation);
    j.key("heading");
    write_quantiles(j, s.heading);
    j.end_object().key("vs_oracle").begin_object().key("translation");
    write_quantiles(j, o.translation);
    j.key("heading");
    write_quantiles(j, o.heading);
    j.end_object();
    if (kUnderTest[k]) j.member("failures", static_cast<std::uint64_t>(failures[k]));
    j.end_object();
  }
  j.end_object()
      .member("unobservable_worlds", static_cast<std::uint64_t>(unobservable))
      .member("worlds_without_selection", static_cast<std::uint64_t>(without));
  j.key("consistency").begin_object().key("twist_nees_mean");
  write_quantiles(j, nees_q);
  j.key("rest_gyro_scale_sd");
  write_quantiles(j, rest_q);
  j.key("gyro_scale_nees");
  write_quantiles(j, scale_q);
  j.key("gyro_bias_nees");
  write_quantiles(j, bias_q);
  j.key("gyro_latency_nees");
  write_quantiles(j, latency_q);
  j.end_object();
  j.key("worst").begin_array();
  for (std::size_t i = 0; i < worst; ++i) {
    j.begin_object()
        .member("seed", order[i]->seed)
        .member("world", order[i]->world)
        .member("command", command_of(order[i]->seed, order[i]->family))
        .end_object();
  }
  j.end_array().key("runs").begin_array();
  for (const auto& r : results) {
    j.begin_object().member("seed", r.seed).member("family", r.family).member("world", r.world);
    j.key("unobservable").begin_array();
    for (const auto& u : r.unobservable) j.value(u);
    j.end_array();
    for (std::size_t k = 0; k < kMethods; ++k) {
      const Figures& f = r.m[k];
      if (!f.run) continue;
      j.key(kNames[k]).begin_object();
      if (f.error.empty()) {
        j.member("max_translation_m", f.translation).member("max_heading_rad", f.heading);
      } else {
        j.member("error", f.error);
      }
      j.end_object();
    }
    if (std::isfinite(r.nees)) j.member("twist_nees_mean", r.nees);
    j.member("failure", r.failure).end_object();
  }
  j.end_array().end_object();
  return {t, j.str() + "\n"};
}

}  // namespace moa::experiments
