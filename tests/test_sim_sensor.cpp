// The simulated optical sensor: counts against the measurement model of
// docs/formats/config.md written out independently here, quantisation with carried
// remainders, the downsampler, the delta register, SQUAL.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <string>

#include "moa/sim/optical.hpp"
#include "moa/sim/scenario.hpp"
#include "moa/sim/simulate.hpp"

namespace moa::sim {
namespace {

// docs/formats/config.md, term by term (not through SensorMount): counts over dt of
// a constant twist.
Eigen::Vector2d model_counts(const SensorMount& m, const Twist2& x, double dt) {
  const double ux = x.v.x() - x.omega * m.position.y();
  const double uy = x.v.y() + x.omega * m.position.x();
  const double c = std::cos(m.yaw);
  const double s = std::sin(m.yaw);
  const double wx = c * ux + s * uy;
  double wy = -s * ux + c * uy;
  if (m.mirrored) wy = -wy;
  const double k = m.cpi / 0.0254;
  return {k * m.scale.x() * wx * dt, k * m.scale.y() * wy * dt};
}

// A robot with yaw, per-axis scale, a cpi that differs from nominal and a
// mirrored sensor, driven through constant twists that switch on row
// boundaries (multiples of 0.01 s), no noise.
std::string model_scenario(const std::string& preset, int k) {
  return R"(version: 1
name: model
sensor_model:
  preset: )" +
         preset + R"(
  packets_per_row: )" +
         std::to_string(k) + R"(
sensors:
  - {name: a, position: [0.08, 0.03], yaw: 0.4}
  - {name: b, position: [-0.05, 0.09], yaw: 2.2, mirrored: true}
  - {name: c, position: [-0.02, -0.1], yaw: -1.3, cpi: 1200}
true_sensors:
  a: {position_error: [0.003, -0.002], yaw_error: 0.03, scale: [1.04, 0.97]}
  b: {scale: [0.98, 1.02], cpi: 1000}
  c: {position_scale: 1.05, mirrored: true}
motion:
  type: twists
  segments:
    - {twist: [0.2, 0.05, 0.8], duration: 0.37}
    - {twist: [-0.1, 0.25, -1.5], duration: 0.5}
    - {twist: [0.0, 0.0, 2.0], duration: 0.23}
    - {twist: [0.3, -0.2, 0.0], duration: 0.4}
)";
}

struct Segment {
  Twist2 x;
  double duration;
};
const std::vector<Segment> kSegments = {{{{0.2, 0.05}, 0.8}, 0.37},
                                        {{{-0.1, 0.25}, -1.5}, 0.5},
                                        {{{0.0, 0.0}, 2.0}, 0.23},
                                        {{{0.3, -0.2}, 0.0}, 0.4}};

// Exact cumulative counts of sensor m from 0 to t.
Eigen::Vector2d exact_total(const SensorMount& m, double t) {
  Eigen::Vector2d total = Eigen::Vector2d::Zero();
  double start = 0.0;
  for (const auto& s : kSegments) {
    const double overlap = std::clamp(t - start, 0.0, s.duration);
    total += model_counts(m, s.x, overlap);
    start += s.duration;
  }
  return total;
}

TEST(SimSensor, CountsFollowTheModelForEveryPreset) {
  // Quantisation: the emitted running total is round() of the real running
  // total, so it is within half a count of the exact integral at every row
  // (plus the rounding of summing ~4000 frames, far below 1e-6 count).
  for (const auto& [preset, k] :
       {std::pair{std::string(kHdns2051.name), 23}, std::pair{std::string(kAdns3080.name), 64}}) {
    const Scenario s = parse_scenario(model_scenario(preset, k), "model.yaml");
    ASSERT_EQ(s.truth.array[1].cpi, 1000.0);  // true_sensors' cpi
    ASSERT_EQ(s.truth.array[2].cpi, 1200.0);  // the list's cpi, kept by the true robot
    const SimLog log = simulate(s, 3);
    std::vector<Eigen::Vector2d> emitted(3, Eigen::Vector2d::Zero());
    std::size_t rows = 0;
    for (const auto& r : log.mice) {
      emitted[static_cast<std::size_t>(r.sensor)] += r.row.counts.cast<double>();
      const Eigen::Vector2d exact = exact_total(s.truth.array[r.sensor], r.t);
      EXPECT_LE((emitted[static_cast<std::size_t>(r.sensor)] - exact).cwiseAbs().maxCoeff(),
                0.5 + 1e-6)
          << preset << " sensor " << r.sensor << " t " << r.t;
      EXPECT_EQ(r.row.faults, 0);
      ++rows;
    }
    // 1.5 s in rows of 0.01 s, plus the zero row at t = 0, for 3 sensors.
    EXPECT_EQ(rows, 3u * 151u) << preset;
    // The nominal robot is not the true one: the counts do not follow it.
    const Eigen::Vector2d nominal = exact_total(s.nominal.array[0], 1.5);
    EXPECT_GT((emitted[0] - nominal).cwiseAbs().maxCoeff(), 100.0) << preset;
  }
}

TEST(SimSensor, ASpeedScaleUnderCountsByItsRatioAtTheSensorsSpeed) {
  // model_scenario with sensor a's true table: ratio 1 up to 0.1 m/s, 0.9
  // from 0.4 m/s, linear between. Each segment's twist is constant, so is
  // the sensor point's speed |v + omega J p|: its counts are the model's
  // times the ratio there, written out here.
  std::string text = model_scenario(std::string(kAdns3080.name), 64);
  const std::string key =
      "  a: {position_error: [0.003, -0.002], yaw_error: 0.03, scale: [1.04, 0.97]}";
  ASSERT_NE(text.find(key), std::string::npos);
  text.replace(text.find(key), key.size(),
               "  a: {position_error: [0.003, -0.002], yaw_error: 0.03, scale: [1.04, 0.97],\n"
               "      speed_scale: {speeds: [0.1, 0.4], ratios: [1.0, 0.9]}}");
  const Scenario s = parse_scenario(text, "model.yaml");
  ASSERT_TRUE(s.truth.array[0].speed_scale.active());
  ASSERT_FALSE(s.nominal.array[0].speed_scale.active());
  const SensorMount& m = s.truth.array[0];
  const auto ratio = [](double v) {
    return v <= 0.1 ? 1.0 : v >= 0.4 ? 0.9 : 1.0 - (v - 0.1) / 3.0;
  };
  Eigen::Vector2d expected = Eigen::Vector2d::Zero();
  std::vector<double> ratios;
  for (const auto& seg : kSegments) {
    const double v = std::hypot(seg.x.v.x() - seg.x.omega * m.position.y(),
                                seg.x.v.y() + seg.x.omega * m.position.x());
    ratios.push_back(ratio(v));
    expected += ratio(v) * model_counts(m, seg.x, seg.duration);
  }
  // Every segment's speed is inside the table (0.14 to 0.36 m/s): each under-counts.
  for (const double r : ratios) {
    EXPECT_LT(r, 0.99);
    EXPECT_GT(r, 0.9);
  }
  const SimLog log = simulate(s, 3);
  Eigen::Vector2d total = Eigen::Vector2d::Zero(), other = Eigen::Vector2d::Zero();
  for (const auto& r : log.mice) {
    if (r.sensor == 0) total += r.row.counts.cast<double>();
    if (r.sensor == 1) other += r.row.counts.cast<double>();
  }
  // Quantised with the remainder carried: within half a count of the total.
  EXPECT_LE((total - expected).cwiseAbs().maxCoeff(), 0.5 + 1e-6);
  // Sensor b has no table: its counts are the model's.
  EXPECT_LE((other - exact_total(s.truth.array[1], 1.5)).cwiseAbs().maxCoeff(), 0.5 + 1e-6);
}

TEST(SimSensor, LongRunTotalsAreExactToOneCount) {
  // A minute of spinning at 3 rad/s: ~1.7e6 counts per sensor in 6000 rows.
  // Closed form: the sensor point's velocity is constant in the robot
  // frame, omega J p, so the total is the model times 60 s.
  const Scenario s = parse_scenario(R"(version: 1
name: spin
sensor_model: {preset: HDNS-2051, packets_per_row: 23}
sensors: {layout: polygon, n: 3, radius: 0.3, theta: -0.5235987755982988}
motion:
  type: twists
  segments: [{twist: [0, 0, 3.0], duration: 60}]
)",
                                    "spin.yaml");
  const SimLog log = simulate(s, 1);
  std::vector<Eigen::Vector2d> total(3, Eigen::Vector2d::Zero());
  for (const auto& r : log.mice)
    total[static_cast<std::size_t>(r.sensor)] += r.row.counts.cast<double>();
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector2d exact = model_counts(s.truth.array[i], {{0, 0}, 3.0}, 60.0);
    EXPECT_GT(exact.norm(), 1e6);
    EXPECT_LE((total[static_cast<std::size_t>(i)] - exact).cwiseAbs().maxCoeff(), 1.0)
        << "sensor " << i;
  }
}

TEST(SimSensor, QuantiserCarriesTheRemainder) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> counts(-3.7, 3.7);
  CountQuantiser q;
  long double sum_x = 0.0L, sum_y = 0.0L;
  Eigen::Vector2i emitted(0, 0);
  for (int i = 0; i < 100000; ++i) {
    const Eigen::Vector2d c(counts(rng), 0.01 * counts(rng));
    sum_x += c.x();
    sum_y += c.y();
    emitted += q.push(c);
    ASSERT_LE(std::abs(emitted.x() - static_cast<double>(sum_x)), 0.5 + 1e-6);
    ASSERT_LE(std::abs(emitted.y() - static_cast<double>(sum_y)), 0.5 + 1e-6);
  }
}

TEST(SimSensor, RowsAreSumsOfKFrames) {
  // The same run read every frame (K = 1) and through the downsampler
  // (K = 23): each K = 23 row is the sum of 23 single-frame rows. Noise on,
  // so that the frames differ.
  const auto yaml = [](int k) {
    return R"(version: 1
name: k
sensor_model: {preset: HDNS-2051, packets_per_row: )" +
           std::to_string(k) + R"(, frame_noise: 0.3, relative_noise: 0.02}
sensors: {layout: radial, angles_deg: [45, 135, 225, 315], distance: 0.1}
motion:
  type: twists
  segments: [{twist: [0.2, -0.1, 1.0], duration: 0.46}]
)";
  };
  const SimLog frames = simulate(parse_scenario(yaml(1), "k1.yaml"), 5);
  const SimLog rows = simulate(parse_scenario(yaml(23), "k23.yaml"), 5);
  ASSERT_EQ(frames.mice.size(), 4u * (1 + 1058));
  ASSERT_EQ(rows.mice.size(), 4u * (1 + 46));
  for (std::size_t r = 4; r < rows.mice.size(); ++r) {
    const MiceRecord& row = rows.mice[r];
    const std::size_t row_index = r / 4;  // 1-based row number
    Eigen::Vector2i sum(0, 0);
    for (std::size_t f = (row_index - 1) * 23 + 1; f <= row_index * 23; ++f) {
      sum += frames.mice[f * 4 + static_cast<std::size_t>(row.sensor)].row.counts;
    }
    EXPECT_EQ(row.row.counts, sum) << "row " << row_index << " sensor " << row.sensor;
    EXPECT_NEAR(row.t, static_cast<double>(row_index) * 23.0 / 2300.0, 1e-15);
  }
}

TEST(SimSensor, DeltaRegisterClipsAndFlagsOverflow) {
  // 0.5 m/s along the sensor's x axis: 0.5 * 800 / 0.0254 / 2300 = 6.85
  // counts per frame, above a register of +-2: every row is 23 * 2 = 46
  // with the overflow flag; the clean (unclipped) counts are clipped too,
  // overflow not being a fault.
  const Scenario s = parse_scenario(R"(version: 1
name: clip
sensor_model: {preset: HDNS-2051, packets_per_row: 23, delta_limit: 2}
sensors:
  - {name: a, position: [0, 0], yaw: 0}
  - {name: b, position: [0, 0.1], yaw: 0}
motion:
  type: twists
  segments: [{twist: [0.5, 0.0, 0.0], duration: 0.2}]
)",
                                    "clip.yaml");
  const SimLog log = simulate(s, 1);
  for (const auto& r : log.mice) {
    if (r.t == 0.0) continue;
    EXPECT_EQ(r.row.counts.x(), 46);
    EXPECT_EQ(r.row.counts.y(), 0);
    EXPECT_EQ(r.row.flags & kFlagOverflow, kFlagOverflow);
    EXPECT_EQ(r.row.faults, 0);
  }
}

TEST(SimSensor, SqualHasTheConfiguredMeanAndJitter) {
  const Scenario s = parse_scenario(R"(version: 1
name: squal
sensor_model: {preset: HDNS-2051, squal: 90, squal_jitter: 4}
sensors: {layout: radial, angles_deg: [0, 180], distance: 0.1}
motion: {type: twists, segments: [{twist: [0.1, 0, 0], duration: 20}]}
)",
                                    "squal.yaml");
  const SimLog log = simulate(s, 2);
  double sum = 0.0, sum_sq = 0.0;
  for (const auto& r : log.mice) {
    sum += r.row.squal;
    sum_sq += double(r.row.squal) * r.row.squal;
  }
  const double n = static_cast<double>(log.mice.size());
  const double mean = sum / n;
  const double sd = std::sqrt(sum_sq / n - mean * mean);
  // Rounding to integers adds 1/12 to the variance. 5 sigma bounds: the mean
  // of n draws has sd 4 / sqrt(n); the sample sd has sd ~ 4 / sqrt(2 n).
  EXPECT_NEAR(mean, 90.0, 5.0 * 4.0 / std::sqrt(n));
  EXPECT_NEAR(sd, std::sqrt(16.0 + 1.0 / 12.0), 5.0 * 4.0 / std::sqrt(2.0 * n));
}

}  // namespace
}  // namespace moa::sim
