// Per-update cost of moa's estimators against the literal formulations
// (pseudo-inverses recomputed per update on dynamic matrices, as Sekimori &
// Miyazaki eqs. (5) and (9) are written). Compare within one run:
//   build/bench/moa_benchmarks --benchmark_filter=/4
#include <benchmark/benchmark.h>

#include <cmath>
#include <numbers>
#include <variant>
#include <vector>

#include "moa/core/consensus.hpp"
#include "moa/core/estimate.hpp"
#include "moa/core/sekimori.hpp"
#include "moa_bench/baselines.hpp"

namespace {

moa::SensorArray radial(int n) {
  std::vector<moa::SensorMount> m(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const double phi = std::numbers::pi / 4.0 + i * 2.0 * std::numbers::pi / n;
    m[static_cast<std::size_t>(i)].position = 0.1 * Eigen::Vector2d(std::cos(phi), std::sin(phi));
    m[static_cast<std::size_t>(i)].yaw = phi;
  }
  return moa::SensorArray(m);
}

moa::ArraySample sample_for(const moa::SensorArray& a) {
  moa::ArraySample s;
  s.size = a.size();
  s.dt = 0.01;
  const moa::Twist2 x{{0.2, -0.1}, 0.4};
  for (int i = 0; i < a.size(); ++i) {
    s.counts[static_cast<std::size_t>(i)] = a[i].counts(x, s.dt).array().round();
    s.squal[static_cast<std::size_t>(i)] = 255;
  }
  return s;
}

void BM_Ls(benchmark::State& state) {
  const auto a = radial(static_cast<int>(state.range(0)));
  const auto est =
      std::get<moa::LsEstimator>(moa::LsEstimator::create(a, moa::all_sensors(a.size()), 0.01));
  const auto s = sample_for(a);
  for (auto _ : state) benchmark::DoNotOptimize(est.estimate(s));
}
BENCHMARK(BM_Ls)->Arg(2)->Arg(4)->Arg(8);

void BM_NaiveLs(benchmark::State& state) {
  const auto a = radial(static_cast<int>(state.range(0)));
  const auto s = sample_for(a);
  for (auto _ : state) benchmark::DoNotOptimize(moa::baseline::naive_ls(a, s));
}
BENCHMARK(BM_NaiveLs)->Arg(2)->Arg(4)->Arg(8);

void BM_Sekimori(benchmark::State& state) {
  const auto a = radial(static_cast<int>(state.range(0)));
  auto est = std::get<moa::SekimoriEstimator>(moa::SekimoriEstimator::create(a));
  const auto s = sample_for(a);
  for (auto _ : state) benchmark::DoNotOptimize(est.estimate(s));
}
BENCHMARK(BM_Sekimori)->Arg(2)->Arg(4)->Arg(8);

void BM_NaiveSekimori(benchmark::State& state) {
  const auto a = radial(static_cast<int>(state.range(0)));
  const auto s = sample_for(a);
  const int r_th = std::max(1, a.size() - 2);
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        moa::baseline::naive_sekimori(a, s, moa::SekimoriOptions{}.e_th, r_th));
  }
}
BENCHMARK(BM_NaiveSekimori)->Arg(2)->Arg(4)->Arg(8);

void BM_Consensus(benchmark::State& state) {
  const auto a = radial(static_cast<int>(state.range(0)));
  auto est = std::get<moa::ConsensusEstimator>(moa::ConsensusEstimator::create(a));
  const auto s = sample_for(a);
  for (auto _ : state) benchmark::DoNotOptimize(est.estimate(s));
}
BENCHMARK(BM_Consensus)->Arg(2)->Arg(4)->Arg(8);

}  // namespace
