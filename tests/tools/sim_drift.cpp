// Test tool: how far dead reckoning drifts on a simulated scenario, averaged
// over seeds 1..RUNS as Sekimori & Miyazaki's Table 4 does (mean of each
// run's maximum translation and heading error). Rows: the wheels; plain
// least squares over all sensors and over two of them (no fault handling);
// and an oracle that uses only the sensors without a fault in faults truth
// (wheels when fewer than two are left), the lower bound of any selection.
// This is how the slip and tracking-loss parameters of the sekimori-a/b
// scenarios were set (docs/simulator.md); the robust estimators have their
// own experiment.
//
//   build/tests/sim_drift SCENARIO [RUNS]
#include <fmt/core.h>

#include <cstdlib>
#include <exception>
#include <numbers>
#include <string>
#include <vector>

#include "moa/analysis/evaluate.hpp"
#include "moa/core/dead_reckoner.hpp"
#include "moa/core/estimate.hpp"
#include "moa/sim/scenario.hpp"
#include "moa/sim/simulate.hpp"

namespace {

using namespace moa;

struct Errors {
  double translation_mm = 0.0;
  double heading_deg = 0.0;
};

Errors errors(const std::vector<StampedPose>& truth, const std::vector<StampedPose>& estimate) {
  TrajectoryErrorAccumulator acc(truth);
  for (const auto& e : estimate) acc.add(e.t, e.pose);
  const TrajectoryError r = acc.result();
  return {r.max_translation * 1000.0, r.max_heading * 180.0 / std::numbers::pi};
}

int run(const std::string& name, int runs) {
  const sim::Scenario s = sim::load_scenario(name);
  const int n = s.nominal.array.size();
  const double dt = s.sensor_model.row_period();
  struct Row {
    std::string label;
    SensorMask mask;  // 0: wheels; ~0: oracle
    Errors sum;
  };
  std::vector<Row> rows = {{"wheels", 0, {}},
                           {fmt::format("{} mice, least squares", n), all_sensors(n), {}}};
  if (n >= 3) {
    rows.push_back({fmt::format("{} and {}, least squares", s.nominal.names[0], s.nominal.names[2]),
                    0b101u,
                    {}});
    rows.push_back({fmt::format("{} and {}, least squares", s.nominal.names[0], s.nominal.names[1]),
                    0b011u,
                    {}});
  }
  rows.push_back({"oracle selection", ~SensorMask{0}, {}});
  std::size_t faulty = 0;

  for (int seed = 1; seed <= runs; ++seed) {
    const sim::SimLog log = sim::simulate(s, static_cast<std::uint64_t>(seed));
    std::vector<StampedPose> truth;
    for (const auto& t : log.truth) truth.push_back({t.t, t.pose});
    // Samples at the rows' common times (every sensor reports each K frames).
    std::vector<ArraySample> samples;
    std::vector<SensorMask> good;
    for (std::size_t i = static_cast<std::size_t>(n);
         i + static_cast<std::size_t>(n) <= log.mice.size(); i += static_cast<std::size_t>(n)) {
      ArraySample sample;
      sample.t = log.mice[i].t;
      sample.dt = dt;
      sample.size = n;
      SensorMask ok = 0;
      for (int j = 0; j < n; ++j) {
        const auto& r = log.mice[i + static_cast<std::size_t>(j)].row;
        sample.counts[static_cast<std::size_t>(j)] = r.counts.cast<double>();
        if (r.faults == 0) ok |= SensorMask{1} << j;
        faulty += r.faults != 0;
      }
      samples.push_back(sample);
      good.push_back(ok);
    }
    const auto wheel_twist = [&](double t) {
      for (const auto& w : log.wheels) {
        if (w.t >= t - 1e-9) return w.twist;
      }
      return log.wheels.empty() ? Twist2{} : log.wheels.back().twist;
    };
    for (auto& row : rows) {
      DeadReckoner dr;
      std::vector<StampedPose> path;
      if (row.mask == 0) {
        double prev = 0.0;
        for (const auto& w : log.wheels) {
          path.push_back({w.t, dr.step(w.twist, w.t - prev)});
          prev = w.t;
        }
      } else {
        for (std::size_t k = 0; k < samples.size(); ++k) {
          const SensorMask mask = row.mask == ~SensorMask{0} ? good[k] : row.mask;
          Twist2 x = wheel_twist(samples[k].t);
          if (count_sensors(mask) >= 2) {
            const auto built = LsEstimator::create(s.nominal.array, mask, dt);
            if (const auto* e = std::get_if<LsEstimator>(&built))
              x = e->estimate(samples[k])->twist;
          }
          path.push_back({samples[k].t, dr.step(x, samples[k].dt)});
        }
      }
      if (path.empty()) continue;
      const Errors e = errors(truth, path);
      row.sum.translation_mm += e.translation_mm;
      row.sum.heading_deg += e.heading_deg;
    }
  }
  fmt::print("{}: {} runs, {:.0f} sensor rows with a fault per run\n", s.name, runs,
             static_cast<double>(faulty) / runs);
  fmt::print("  {:<28} {:>10} {:>10}\n", "mean of max error", "mm", "deg");
  for (const auto& row : rows) {
    fmt::print("  {:<28} {:>10.1f} {:>10.2f}\n", row.label, row.sum.translation_mm / runs,
               row.sum.heading_deg / runs);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || argc > 3) {
    fmt::print(stderr, "usage: sim_drift SCENARIO [RUNS]\n");
    return 2;
  }
  try {
    return run(argv[1], argc == 3 ? std::atoi(argv[2]) : 10);
  } catch (const std::exception& e) {
    fmt::print(stderr, "sim_drift: {}\n", e.what());
    return 1;
  }
}
