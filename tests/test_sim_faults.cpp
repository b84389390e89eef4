// Fault models: each appears where the scenario puts it and nowhere else,
// with the effect its description promises; tracking loss follows speed.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <string>

#include "moa/sim/scenario.hpp"
#include "moa/sim/simulate.hpp"

namespace moa::sim {
namespace {

// 5 s under the rated speed (0.2 m/s and 0.6 rad/s: sensor points below
// 0.27 m/s), four HDNS-2051, noise on; `faults` appended.
std::string base_scenario(const std::string& faults) {
  return R"(version: 1
name: faults
sensor_model: {preset: HDNS-2051, packets_per_row: 23, frame_noise: 0.05, relative_noise: 0.01,
               squal: 90, squal_jitter: 3}
sensors: {layout: radial, angles_deg: [45, 135, 225, 315], distance: 0.1}
motion:
  type: twists
  segments: [{twist: [0.2, 0.05, 0.6], duration: 2.5}, {twist: [-0.1, 0.15, -0.6], duration: 2.5}]
)" + faults;
}

struct Window {
  int sensor;
  double start, end;
  std::uint8_t bit;
};

// Frames of the row ending at t (K frames of h) whose midpoint is in [start, end).
int frames_inside(double t, const Window& w, int k, double h) {
  int inside = 0;
  for (int j = 0; j < k; ++j) {
    const double mid = t - (j + 0.5) * h;
    if (mid >= w.start && mid < w.end) ++inside;
  }
  return inside;
}

TEST(SimFaults, FaultsAppearOnlyWhereTheScenarioPutsThem) {
  const std::vector<Window> windows = {{1, 1.0, 1.5, kFaultLiftoff},
                                       {2, 2.0, 2.6, kFaultDirty},
                                       {3, 3.0, 4.0, kFaultSpike},
                                       {0, 4.2, 4.5, kFaultStuck}};
  const SimLog clean = simulate(parse_scenario(base_scenario(""), "clean.yaml"), 9);
  const SimLog faulty = simulate(parse_scenario(base_scenario(R"(faults:
  events:
    - {type: liftoff, sensor: m2, start: 1.0, end: 1.5}
    - {type: dirty, sensor: m3, start: 2.0, end: 2.6, retained: 0.3, squal: 12}
    - {type: spikes, sensor: m4, start: 3.0, end: 4.0, rate: 20, magnitude: 30}
    - {type: stuck, sensor: m1, start: 4.2, end: 4.5}
)"),
                                                "faulty.yaml"),
                                 9);
  ASSERT_EQ(clean.mice.size(), faulty.mice.size());
  const double h = 1.0 / 2300.0;
  int spikes = 0;
  std::optional<Eigen::Vector2i> stuck_counts;
  for (std::size_t i = 0; i < faulty.mice.size(); ++i) {
    const MiceRecord& f = faulty.mice[i];
    const MiceRecord& c = clean.mice[i];
    ASSERT_EQ(f.t, c.t);
    const Window& w = windows[f.sensor == 0 ? 3 : static_cast<std::size_t>(f.sensor - 1)];
    const int inside = f.t == 0.0 ? 0 : frames_inside(f.t, w, 23, h);
    // Same noise streams: the clean counts are the fault-free run's.
    EXPECT_EQ(f.row.clean, c.row.counts) << "t " << f.t << " sensor " << f.sensor;
    if (inside == 0) {
      EXPECT_EQ(f.row.faults, 0) << "t " << f.t << " sensor " << f.sensor;
      EXPECT_EQ(f.row.faulty_frames, 0);
      EXPECT_EQ(f.row.flags, 0);
      if (f.t <= w.start) {
        EXPECT_EQ(f.row.counts, c.row.counts) << "t " << f.t << " sensor " << f.sensor;
      } else {
        // After a fault the counts are the clean ones again, but the
        // fraction carried in the quantiser differs: one count at most.
        EXPECT_LE((f.row.counts - c.row.counts).cwiseAbs().maxCoeff(), 1)
            << "t " << f.t << " sensor " << f.sensor;
      }
      continue;
    }
    if (w.bit == kFaultSpike) {
      // A spike is an event within the window: rows in it may or may not have one.
      EXPECT_EQ(f.row.faults & ~kFaultSpike, 0);
      if (f.row.faults != 0) {
        ++spikes;
        // One spike in the row: the row moved by 30 counts. Each axis of
        // either row is a difference of two roundings (+-1), so the two rows
        // differ from "clean + spike" by at most 2 per axis, 2 sqrt 2 in
        // norm. Two spikes may cancel, so are not checked.
        if (f.row.faulty_frames == 1) {
          EXPECT_NEAR((f.row.counts - c.row.counts).cast<double>().norm(), 30.0,
                      2.0 * std::sqrt(2.0));
        }
      } else {
        // Clean again; an earlier spike may have shifted the carried fraction.
        EXPECT_LE((f.row.counts - c.row.counts).cwiseAbs().maxCoeff(), 1);
      }
      continue;
    }
    EXPECT_EQ(f.row.faults, w.bit) << "t " << f.t << " sensor " << f.sensor;
    EXPECT_EQ(f.row.faulty_frames, inside);
    if (inside < 23) continue;  // a row half in the window: mixed, checked by the counts above
    if (w.bit == kFaultLiftoff) {
      EXPECT_EQ(f.row.counts, Eigen::Vector2i(0, 0));
      EXPECT_EQ(f.row.flags, kFlagLift);
      EXPECT_LE(f.row.squal, 3);
    } else if (w.bit == kFaultDirty) {
      // 0.3 of the real counts, each side rounded within one count.
      const Eigen::Vector2d expected = 0.3 * c.row.counts.cast<double>();
      EXPECT_LE((f.row.counts.cast<double>() - expected).cwiseAbs().maxCoeff(), 1.0 + 0.3);
      EXPECT_LE(f.row.squal, 12);
    } else if (w.bit == kFaultStuck) {
      // Frozen: every full row the same, though the robot's speed changes.
      if (!stuck_counts) stuck_counts = f.row.counts;
      EXPECT_EQ(f.row.counts, *stuck_counts);
    }
  }
  // 20 spikes per second for 1 s: P(none) = e^-20.
  EXPECT_GT(spikes, 0);
  ASSERT_TRUE(stuck_counts.has_value());
  EXPECT_NE(*stuck_counts, Eigen::Vector2i(0, 0));
}

// Drift, both forms docs/simulator.md names: a linear ramp (m2: gain 1 ->
// 0.8 over 2 s from t = 1 s, window to 4 s, where the gain is 1 again) and
// a step (m3: gain 1.25 from t = 2.5 s to past the end, ramp 0: a change of
// floor). Expected gain of a frame: g(mid) = 1 + (scale - 1) min(1, (mid -
// start) / ramp) inside [start, end), 1 outside; a row's expected counts are
// its clean counts times the mean gain of its 23 frames (the counts of one
// row barely change from frame to frame). Both quantisers carry their
// remainder, so the running totals of a sensor's counts differ from the
// expected by at most 0.5 + 1.25 * 0.5 counts, plus what the gain's variation
// within a row does to a row whose counts also vary: 1e-3 of the total.
TEST(SimFaults, DriftIsALinearRampOrAStep) {
  const SimLog log = simulate(parse_scenario(base_scenario(R"(faults:
  events:
    - {type: drift, sensor: m2, start: 1.0, end: 4.0, scale: 0.8, ramp: 2}
    - {type: drift, sensor: m3, start: 2.5, end: 100, scale: 1.25}
)"),
                                             "drift.yaml"),
                              9);
  const double h = 1.0 / 2300.0;
  const auto inside = [](int sensor, double mid) {
    return (sensor == 1 && mid >= 1.0 && mid < 4.0) || (sensor == 2 && mid >= 2.5);
  };
  const auto gain = [&](int sensor, double mid) {
    if (!inside(sensor, mid)) return 1.0;
    return sensor == 1 ? 1.0 - 0.2 * std::min(1.0, (mid - 1.0) / 2.0) : 1.25;
  };
  std::map<int, Eigen::Vector2d> total, expected, magnitude;
  std::map<int, int> drifting_rows;
  for (const MiceRecord& r : log.mice) {
    double g = 0.0;
    bool any = false;
    for (int j = 0; j < 23; ++j) {
      const double mid = r.t - (j + 0.5) * h;
      g += gain(r.sensor, mid) / 23.0;
      any = any || (r.t > 0.0 && inside(r.sensor, mid));
    }
    for (auto* sum : {&total, &expected, &magnitude}) sum->try_emplace(r.sensor, 0.0, 0.0);
    total[r.sensor] += r.row.counts.cast<double>();
    expected[r.sensor] += g * r.row.clean.cast<double>();
    magnitude[r.sensor] += r.row.clean.cast<double>().cwiseAbs();
    const double tol = 0.5 + 1.25 * 0.5 + 1e-3 * magnitude[r.sensor].maxCoeff();
    EXPECT_LE((total[r.sensor] - expected[r.sensor]).cwiseAbs().maxCoeff(), tol)
        << "t " << r.t << " sensor " << r.sensor;
    EXPECT_EQ((r.row.faults & kFaultDrift) != 0, any) << "t " << r.t << " sensor " << r.sensor;
    if (any) ++drifting_rows[r.sensor];
  }
  // The drifts changed the counts by far more than the tolerance: 20 % and 25 %
  // of hundreds of counts per second.
  EXPECT_GT(drifting_rows[1], 250);
  EXPECT_GT(drifting_rows[2], 200);
  EXPECT_EQ(drifting_rows.count(0), 0u);
  EXPECT_EQ(drifting_rows.count(3), 0u);
}

TEST(SimFaults, TrackingLossNeverBelowRatedSpeed) {
  // Speed (a): 0.3 m/s translations, 1.82 rad/s * 0.1 m = 0.182 m/s
  // rotations, all under 14 in/s = 0.3556 m/s.
  for (int seed = 1; seed <= 3; ++seed) {
    const SimLog log = simulate(load_scenario("sekimori-a"), static_cast<std::uint64_t>(seed));
    for (const auto& r : log.mice) ASSERT_EQ(r.row.faults, 0) << "seed " << seed << " t " << r.t;
  }
}

TEST(SimFaults, TrackingLossOnlyWhereASensorIsOverItsRatedSpeed) {
  const Scenario s = load_scenario("sekimori-b");
  const SimLog log = simulate(s, 4);
  // Truth rows are at the mice row times (100 Hz): the twist of each row's
  // last frame. Within a row of 0.01 s a sensor point's speed changes by at
  // most (max_accel + max_angular_accel * 0.1 m) * 0.01 s = 0.02 m/s, so a
  // row with a loss (some frame over 0.3556 m/s) ends above 0.3356 m/s.
  std::map<double, Twist2> twist_at;
  for (const auto& t : log.truth) twist_at[t.t] = t.twist;
  int lost = 0, over = 0;
  for (const auto& r : log.mice) {
    const Twist2 x = twist_at.at(r.t);
    const SensorMount& m = s.truth.array[r.sensor];
    const Eigen::Vector2d u(x.v.x() - x.omega * m.position.y(), x.v.y() + x.omega * m.position.x());
    if (u.norm() > 0.3556) ++over;
    if (r.row.faults == 0) continue;
    ++lost;
    EXPECT_EQ(r.row.faults, kFaultTrackingLoss);
    EXPECT_GT(u.norm(), 0.3556 - 0.02) << "t " << r.t << " sensor " << r.sensor;
  }
  EXPECT_GT(over, 1000);  // the translations at 0.5 m/s
  EXPECT_GT(lost, 0);
  EXPECT_LT(lost, over);
}

TEST(SimFaults, TrackingLossOfOneSensorLeavesTheOthersAlone) {
  // Losses are drawn per sensor from its own stream: switching the model on
  // for the other sensors changes nothing for m1.
  std::string yaml(builtin_scenario_text("sekimori-b"));
  const Scenario all = parse_scenario(yaml, "all.yaml");
  const std::string key = "tracking_loss: {rate: ";
  const auto at = yaml.find(key);
  ASSERT_NE(at, std::string::npos);
  yaml.insert(at + key.size() - std::string("rate: ").size(), "sensors: [m1], ");
  const Scenario one = parse_scenario(yaml, "one.yaml");
  ASSERT_FALSE(one.faults[1].tracking_loss.has_value());
  const SimLog a = simulate(all, 6);
  const SimLog b = simulate(one, 6);
  int m1_lost = 0;
  for (std::size_t i = 0; i < a.mice.size(); ++i) {
    if (a.mice[i].sensor == 0) {
      EXPECT_EQ(a.mice[i].row.counts, b.mice[i].row.counts);
      EXPECT_EQ(a.mice[i].row.faults, b.mice[i].row.faults);
      m1_lost += b.mice[i].row.faults != 0;
    } else {
      EXPECT_EQ(b.mice[i].row.faults, 0);
    }
  }
  EXPECT_GT(m1_lost, 0);
}

TEST(SimFaults, LostCountsAreAFractionOfTheTrueOnes) {
  // retained in [0, 0.5]: a row entirely lost carries at most half the
  // clean counts (plus a count of rounding on each side).
  const SimLog log = simulate(load_scenario("sekimori-b"), 8);
  int full = 0;
  for (const auto& r : log.mice) {
    if (r.row.faulty_frames < 23) continue;
    ++full;
    for (int a = 0; a < 2; ++a) {
      EXPECT_LE(std::abs(r.row.counts[a]), 0.5 * std::abs(r.row.clean[a]) + 2.0);
    }
  }
  EXPECT_GT(full, 0);
}

}  // namespace
}  // namespace moa::sim
