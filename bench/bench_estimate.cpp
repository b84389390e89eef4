// Per-update cost of the least-squares estimator: the precomputed gain
// against a pseudo-inverse recomputed per update on dynamic matrices (the
// way Sekimori & Miyazaki eq. (5) is written). Compare the two in one run.
#include <benchmark/benchmark.h>

#include <Eigen/Dense>
#include <variant>

#include "moa/estimate.hpp"

namespace {

moa::ArraySample sample_for(const moa::SensorArray& a) {
  moa::ArraySample s;
  s.size = a.size();
  s.dt = 0.01;
  const moa::Twist2 x{{0.2, -0.1}, 0.4};
  for (int i = 0; i < a.size(); ++i) s.counts[static_cast<std::size_t>(i)] = a[i].counts(x, s.dt);
  return s;
}

void BM_LsPrecomputedGain(benchmark::State& state) {
  const auto a = moa::regular_polygon(static_cast<int>(state.range(0)), 0.1, 0.0);
  const auto est =
      std::get<moa::LsEstimator>(moa::LsEstimator::create(a, moa::all_sensors(a.size()), 0.01));
  const auto s = sample_for(a);
  for (auto _ : state) benchmark::DoNotOptimize(est.estimate(s));
}
BENCHMARK(BM_LsPrecomputedGain)->Arg(2)->Arg(4)->Arg(8);

void BM_LsNaivePseudoInverse(benchmark::State& state) {
  const auto a = moa::regular_polygon(static_cast<int>(state.range(0)), 0.1, 0.0);
  const auto s = sample_for(a);
  const int n = a.size();
  for (auto _ : state) {
    Eigen::MatrixXd big_a(2 * n, 3);
    Eigen::VectorXd u(2 * n);
    for (int i = 0; i < n; ++i) {
      big_a.middleRows(2 * i, 2) = a[i].point_jacobian();
      u.segment(2 * i, 2) =
          a[i].robot_velocity_from_counts() * s.counts[static_cast<std::size_t>(i)] / s.dt;
    }
    const Eigen::MatrixXd pinv = big_a.completeOrthogonalDecomposition().pseudoInverse();
    benchmark::DoNotOptimize(Eigen::VectorXd(pinv * u));
  }
}
BENCHMARK(BM_LsNaivePseudoInverse)->Arg(2)->Arg(4)->Arg(8);

}  // namespace
