#include "moa_bench/estimators.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <numbers>
#include <random>
#include <variant>

#include "moa/core/consensus.hpp"
#include "moa/core/estimate.hpp"
#include "moa/core/sekimori.hpp"
#include "moa_bench/baselines.hpp"

namespace moa::bench {
namespace {

/// N sensors radial around the robot (Sekimori & Miyazaki's layout), HDNS-2051.
SensorArray radial_array(int n) {
  std::vector<SensorMount> mounts(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const double phi = std::numbers::pi / 4.0 + i * 2.0 * std::numbers::pi / n;
    auto& m = mounts[static_cast<std::size_t>(i)];
    m.position = 0.1 * Eigen::Vector2d(std::cos(phi), std::sin(phi));
    m.yaw = phi;
    m.cpi = kHdns2051.cpi;
    m.max_speed = kHdns2051.max_speed;
  }
  return SensorArray(mounts);
}

/// 100 Hz samples of random motion, quantised; one in ten has a sensor that lost track.
std::vector<ArraySample> workload(const SensorArray& array, std::size_t count) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> v(-0.3, 0.3), w(-1.5, 1.5);
  std::vector<ArraySample> samples(count);
  for (std::size_t k = 0; k < count; ++k) {
    ArraySample& s = samples[k];
    s.t = 0.01 * static_cast<double>(k + 1);
    s.dt = 0.01;
    s.size = array.size();
    const Twist2 x{{v(rng), v(rng)}, w(rng)};
    for (int i = 0; i < array.size(); ++i) {
      const auto u = static_cast<std::size_t>(i);
      s.counts[u] = array[i].counts(x, s.dt).array().round();
      s.squal[u] = 255;
    }
    if (k % 10 == 3) s.counts[k % static_cast<std::size_t>(array.size())] *= 0.3;
  }
  return samples;
}

/// Results land here so that the optimiser cannot drop the work.
volatile double g_sink = 0.0;

/// Median over batches of the time per update (ns).
template <class F>
double median_ns(const EstimatorBenchOptions& args, const std::vector<ArraySample>& samples,
                 F&& update) {
  std::vector<double> per_update;
  double sink = 0.0;
  for (int b = 0; b < args.batches; ++b) {
    const auto start = std::chrono::steady_clock::now();
    for (int k = 0; k < args.updates; ++k) {
      sink += update(samples[static_cast<std::size_t>(k) % samples.size()]);
    }
    const auto stop = std::chrono::steady_clock::now();
    per_update.push_back(std::chrono::duration<double, std::nano>(stop - start).count() /
                         args.updates);
  }
  g_sink = sink;
  std::nth_element(per_update.begin(), per_update.begin() + args.batches / 2, per_update.end());
  return per_update[static_cast<std::size_t>(args.batches / 2)];
}

EstimatorCosts bench_n(const EstimatorBenchOptions& args, int n) {
  const SensorArray array = radial_array(n);
  const auto samples = workload(array, 64);
  const auto ls = std::get<LsEstimator>(LsEstimator::create(array, all_sensors(n), 0.01));
  auto sekimori = std::get<SekimoriEstimator>(SekimoriEstimator::create(array));
  auto consensus = std::get<ConsensusEstimator>(ConsensusEstimator::create(array));
  const int r_th = sekimori.r_th();
  const double e_th = SekimoriOptions{}.e_th;
  EstimatorCosts r;
  r.n = n;
  r.ls =
      median_ns(args, samples, [&](const ArraySample& s) { return ls.estimate(s)->twist.omega; });
  r.naive_ls = median_ns(args, samples,
                         [&](const ArraySample& s) { return baseline::naive_ls(array, s).omega; });
  r.sekimori = median_ns(args, samples, [&](const ArraySample& s) {
    return sekimori.estimate(s)->estimate.twist.omega;
  });
  r.naive_sekimori = median_ns(args, samples, [&](const ArraySample& s) {
    return baseline::naive_sekimori(array, s, e_th, r_th).omega;
  });
  r.consensus = median_ns(args, samples, [&](const ArraySample& s) {
    return consensus.estimate(s)->estimate.twist.omega;
  });
  return r;
}

}  // namespace

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      if (colon != std::string::npos) return line.substr(colon + 2);
    }
  }
  return "unknown";
}

std::vector<EstimatorCosts> bench_estimators(const EstimatorBenchOptions& options,
                                             void (*progress)(int n)) {
  std::vector<EstimatorCosts> rows;
  for (const int n : options.sizes) {
    if (progress != nullptr) progress(n);
    rows.push_back(bench_n(options, n));
  }
  return rows;
}

}  // namespace moa::bench
