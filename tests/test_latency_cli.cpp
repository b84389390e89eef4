// Stream latencies end to end: a log whose rows are stamped late, by a
// different amount per sensor and for the wheels, run with those latencies
// in the config, gives the run of the same rows at their true times.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "moa/analysis/evaluate.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/log.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa {
namespace {
namespace fs = std::filesystem;

std::vector<std::pair<double, Pose2>> read_poses(const fs::path& odometry) {
  std::vector<std::pair<double, Pose2>> poses;
  io::TruthReader reader(odometry);
  while (const auto row = reader.next()) poses.emplace_back(row->t, row->pose);
  return poses;
}

// The largest distance between the poses of `a` and `b` at a's times up to
// `until` (b holds every time of a, and maybe more at its end).
double largest_difference(const std::vector<std::pair<double, Pose2>>& a,
                          const std::vector<std::pair<double, Pose2>>& b, double until = INFINITY) {
  double worst = 0.0;
  std::size_t j = 0;
  for (const auto& [t, pose] : a) {
    if (t > until) break;
    while (j < b.size() && b[j].first < t - 1e-9) ++j;
    if (j == b.size() || std::abs(b[j].first - t) > 1e-9) return INFINITY;
    worst = std::max(worst, (b[j].second.t - pose.t).norm());
  }
  return worst;
}

// Writes wheels.csv: the truth's twist over each row interval, stamped
// `latency` s late. An opening row one period before the first makes the
// first row cover the log's first epoch whole: a stamp minus its latency is
// the true time up to rounding only, and an epoch that the first row
// opens at that time, not covered at all on time, would be covered by a
// sliver of the next row when late.
void write_wheels(const test::SynthLog& log, double latency, const fs::path& path) {
  std::ofstream out(path);
  out << "t,vx,vy,omega\n";
  char line[160];
  std::snprintf(line, sizeof line, "%.6f,0,0,0\n", 2 * log.truth[0].t - log.truth[1].t + latency);
  out << line;
  for (std::size_t k = 1; k < log.truth.size(); ++k) {
    const StampedPose& a = log.truth[k - 1];
    const StampedPose& b = log.truth[k];
    const Twist2 x = twist_between(a.pose, b.pose, b.t - a.t);
    std::snprintf(line, sizeof line, "%.6f,%.9f,%.9f,%.9f\n", b.t + latency, x.v.x(), x.v.y(),
                  x.omega);
    out << line;
  }
}

TEST(LatencyCli, LateRowsWithTheirLatenciesGiveTheRunOfTheTrueTimes) {
  const SensorArray array = test::skewed_array();
  const std::vector<std::string> names{"a", "b", "c", "d"};
  const test::SynthLog log = test::synthesise(array, test::mixed_motion, 20.0, 0.01);
  const fs::path on_time = test::scratch_dir("latency-on-time");
  const fs::path late = test::scratch_dir("latency-late");
  test::write_log(log, array, names, on_time);
  write_wheels(log, 0.0, on_time / "wheels.csv");

  // Each sensor's rows stamped late by its own latency (one on time, so
  // that both logs start at the same time), mice.csv sorted by stamp.
  const std::array<double, 4> latency{0.0, 0.003, 0.007, 0.012};
  test::SynthLog stamped = log;
  for (auto& row : stamped.rows) row.t += latency[static_cast<std::size_t>(row.sensor)];
  std::stable_sort(stamped.rows.begin(), stamped.rows.end(),
                   [](const test::SynthRow& a, const test::SynthRow& b) { return a.t < b.t; });
  test::write_log(stamped, array, names, late);
  write_wheels(log, 0.02, late / "wheels.csv");
  io::RobotConfig config = io::read_config(late / "robot.yaml");
  const fs::path naive = late / "naive.yaml";
  io::write_config(config, naive);
  for (int i = 0; i < config.array.size(); ++i) {
    config.array[i].latency = latency[static_cast<std::size_t>(i)];
  }
  config.wheels_latency = 0.02;
  io::write_config(config, late / "robot.yaml");

  const auto run = [](const fs::path& config_path, const fs::path& dir, const char* out,
                      const std::string& flags = "") {
    const auto r = test::run_moa("odometry --config " + config_path.string() + " --log " +
                                 dir.string() + " --out " + (dir / out).string() + flags);
    EXPECT_EQ(r.exit_code, 0) << r.err;
  };
  run(on_time / "robot.yaml", on_time, "o.csv");
  run(late / "robot.yaml", late, "o.csv");
  run(naive, late, "naive.csv");
  // The wheels alone, to see their latency (with the mice they are only a check).
  run(on_time / "robot.yaml", on_time, "w.csv", " --estimator wheels");
  run(late / "robot.yaml", late, "w.csv", " --estimator wheels");
  run(naive, late, "w-naive.csv", " --estimator wheels");
  const auto wheels_run = read_poses(on_time / "w.csv");
  // The run ends with the last mice row: a wheel row stamped after it (its
  // true end is the last epoch's) is not read, so the last epoch differs.
  EXPECT_LT(largest_difference(wheels_run, read_poses(late / "w.csv"), 19.99 - 1e-9), 1e-6);
  EXPECT_GT(largest_difference(wheels_run, read_poses(late / "w-naive.csv")), 1e-3);
  const auto truth_run = read_poses(on_time / "o.csv");
  ASSERT_GT(truth_run.size(), 1900u);
  // The same rows and twists: only rounding of the 1 us stamps apart.
  EXPECT_LT(largest_difference(truth_run, read_poses(late / "o.csv")), 1e-6);
  // Without the latencies the sensors disagree during every acceleration.
  EXPECT_GT(largest_difference(truth_run, read_poses(late / "naive.csv")), 1e-3);
}

TEST(LatencyCli, CameraLatencyComesFromTheConfigAndTheFlagOverridesIt) {
  const SensorArray array = test::skewed_array();
  const test::SynthLog log = test::synthesise(array, test::mixed_motion, 10.0, 0.01);
  const fs::path dir = test::scratch_dir("latency-camera");
  test::write_log(log, array, {"a", "b", "c", "d"}, dir);
  {
    // Exact fixes of the pose at 10 Hz, stamped 0.2 s after capture.
    std::ofstream camera(dir / "camera.csv");
    camera << "t,x,y,sx,sy\n";
    for (std::size_t k = 0; k < log.truth.size(); k += 10) {
      camera << log.truth[k].t + 0.2 << ',' << log.truth[k].pose.t.x() << ','
             << log.truth[k].pose.t.y() << ",0.0005,0.0005\n";
    }
  }
  io::RobotConfig config = io::read_config(dir / "robot.yaml");
  for (int i = 0; i < config.array.size(); ++i) config.array[i].scale *= 1.03;  // drifts
  config.camera_latency = 0.2;
  io::write_config(config, dir / "robot.yaml");
  const std::string common = "odometry --config " + (dir / "robot.yaml").string() + " --log " +
                             dir.string() + " --fuse-camera --out ";
  ASSERT_EQ(test::run_moa(common + (dir / "config.csv").string()).exit_code, 0);
  ASSERT_EQ(test::run_moa(common + (dir / "flag.csv").string() + " --camera-latency 0.2").exit_code,
            0);
  ASSERT_EQ(test::run_moa(common + (dir / "zero.csv").string() + " --camera-latency 0").exit_code,
            0);
  const auto truth = log.truth;
  const auto worst = [&](const char* file) {
    std::vector<std::pair<double, Pose2>> t;
    for (const auto& s : truth) t.emplace_back(s.t, s.pose);
    return largest_difference(read_poses(dir / file), t);
  };
  // The config's latency is the flag's: the same run.
  EXPECT_EQ(read_poses(dir / "config.csv").size(), read_poses(dir / "flag.csv").size());
  EXPECT_LT(largest_difference(read_poses(dir / "config.csv"), read_poses(dir / "flag.csv")),
            1e-12);
  // Taken at their stamps, fixes 0.2 s late pull the pose back along the
  // path (~0.2 s x 0.2 m/s); at their capture time they agree with it.
  EXPECT_LT(worst("config.csv"), 0.01);
  EXPECT_GT(worst("zero.csv"), 2.0 * worst("config.csv"));
}

}  // namespace
}  // namespace moa
