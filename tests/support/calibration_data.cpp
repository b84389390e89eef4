#include "support/calibration_data.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>

namespace moa::test {

Twist2 average_twist(const TwistScript& script, double t0, double t1, double substep) {
  const auto steps = std::max<long>(1, std::lround((t1 - t0) / substep));
  const double h = (t1 - t0) / static_cast<double>(steps);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (long s = 0; s < steps; ++s) {
    sum += script(t0 + (static_cast<double>(s) + 0.5) * h).vector();
  }
  return Twist2::from_vector(sum / static_cast<double>(steps));
}

std::vector<CalibrationSample> reference_samples(const SensorArray& truth,
                                                 const TwistScript& script, double duration,
                                                 double period, bool quantise, ReferenceNoise noise,
                                                 std::uint64_t seed) {
  // Counts and reference both use the midpoint rule on the same substeps,
  // so they agree exactly whatever the substep; 8 per row keeps tests fast.
  const double substep = period / 8.0;
  const SynthLog log = synthesise(truth, script, duration, period, quantise, substep);
  std::vector<double> times;
  for (const auto& s : log.truth) times.push_back(s.t);
  IntervalAccumulator acc(truth.size(), 0.0, times, 2.0 * period);
  for (const auto& r : log.rows) acc.add(SensorRow{r.t, r.sensor, r.counts, std::nullopt, 0});
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::vector<CalibrationSample> out;
  for (const auto& interval : acc.covered()) {
    CalibrationSample s;
    s.mice = interval.sample;
    s.reference = average_twist(script, s.mice.t - s.mice.dt, s.mice.t, substep);
    s.reference.v += noise.speed * Eigen::Vector2d(gauss(rng), gauss(rng));
    s.reference.omega += noise.rate * gauss(rng);
    out.push_back(s);
  }
  return out;
}

void write_wheels(const std::filesystem::path& dir, const TwistScript& script, double duration,
                  double period, ReferenceNoise noise, std::uint64_t seed, double substep) {
  std::filesystem::create_directories(dir);
  std::ofstream out(dir / "wheels.csv");
  out << "t,vx,vy,omega\n";
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const auto rows = std::lround(duration / period);
  char line[160];
  std::snprintf(line, sizeof line, "%.6f,0,0,0\n", 0.0);
  out << line;
  for (long k = 1; k <= rows; ++k) {
    const double t1 = static_cast<double>(k) * period;
    Twist2 x = average_twist(script, t1 - period, t1, substep);
    x.v += noise.speed * Eigen::Vector2d(gauss(rng), gauss(rng));
    x.omega += noise.rate * gauss(rng);
    std::snprintf(line, sizeof line, "%.6f,%.9f,%.9f,%.9f\n", t1, x.v.x(), x.v.y(), x.omega);
    out << line;
  }
}

std::vector<Eigen::Vector2d> count_totals(const SensorArray& truth, const TwistScript& script,
                                          double duration) {
  const SynthLog log = synthesise(truth, script, duration, 0.01, true, 1e-3);
  std::vector<Eigen::Vector2d> totals(static_cast<std::size_t>(truth.size()),
                                      Eigen::Vector2d::Zero());
  for (const auto& r : log.rows) totals[static_cast<std::size_t>(r.sensor)] += r.counts;
  return totals;
}

SensorArray perturbed(const SensorArray& nominal, std::mt19937_64& rng, double position, double yaw,
                      double scale, int mirror) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  SensorArray out = nominal;
  for (int i = 0; i < out.size(); ++i) {
    SensorMount& m = out[i];
    m.position += position * Eigen::Vector2d(unit(rng), unit(rng));
    m.yaw += yaw * unit(rng);
    m.scale =
        m.scale.cwiseProduct(Eigen::Vector2d(1.0 + scale * unit(rng), 1.0 + scale * unit(rng)));
    if (i == mirror) m.mirrored = !m.mirrored;
  }
  return out;
}

SensorArray four_sensor_nominal() {
  std::vector<SensorMount> m(4);
  m[0].position = {0.1, 0.02};
  m[0].yaw = 0.3;
  m[1].position = {-0.02, 0.1};
  m[1].yaw = 1.9;
  m[1].cpi = 1600;
  m[2].position = {-0.1, -0.03};
  m[2].yaw = -2.5;
  m[2].cpi = 1200;
  m[3].position = {0.03, -0.1};
  m[3].yaw = -0.7;
  return SensorArray(m);
}

SensorArray kimlee_nominal() {
  SensorMount proto;
  proto.cpi = 1600.0;
  return regular_polygon(3, 0.3, -std::numbers::pi / 6.0, proto);
}

}  // namespace moa::test
