#include "support/synth.hpp"

#include <cmath>
#include <fstream>
#include <random>
#include <vector>

#include "moa/formats/config.hpp"

namespace moa::test {

ArraySample exact_sample(const SensorArray& array, const Twist2& twist, double t, double dt,
                         const std::function<Mat2(int)>& gain) {
  ArraySample s;
  s.t = t;
  s.dt = dt;
  s.size = array.size();
  for (int i = 0; i < array.size(); ++i) {
    const auto u = static_cast<std::size_t>(i);
    const Vec2 point = twist.v + twist.omega * Vec2(-array[i].position.y(), array[i].position.x());
    s.counts[u] = array[i].robot_velocity_from_counts().inverse() * (gain(i) * point) * dt;
    s.squal[u] = 90;
  }
  return s;
}

SynthLog synthesise(const SensorArray& array, const TwistScript& script, double duration,
                    double row_period, bool quantise, double substep) {
  const int n = array.size();
  SynthLog log;
  std::vector<Eigen::Vector2d> cumulative(static_cast<std::size_t>(n), Eigen::Vector2d::Zero());
  std::vector<Eigen::Vector2d> reported(static_cast<std::size_t>(n), Eigen::Vector2d::Zero());
  Pose2 pose;
  log.truth.push_back({0.0, pose});
  for (int i = 0; i < n; ++i) log.rows.push_back({0.0, i, Eigen::Vector2d::Zero()});

  const auto rows = static_cast<long>(std::llround(duration / row_period));
  const auto steps = static_cast<long>(std::llround(row_period / substep));
  const double h = row_period / static_cast<double>(steps);
  for (long k = 1; k <= rows; ++k) {
    const double t_begin = static_cast<double>(k - 1) * row_period;
    for (long s = 0; s < steps; ++s) {
      const Twist2 x = script(t_begin + (static_cast<double>(s) + 0.5) * h);
      pose = integrate_exact(pose, x, h);
      for (int i = 0; i < n; ++i) cumulative[static_cast<std::size_t>(i)] += array[i].counts(x, h);
    }
    const double t = static_cast<double>(k) * row_period;
    log.truth.push_back({t, pose});
    for (int i = 0; i < n; ++i) {
      const auto u = static_cast<std::size_t>(i);
      const Eigen::Vector2d now =
          quantise ? Eigen::Vector2d(cumulative[u].array().round()) : cumulative[u];
      log.rows.push_back({t, i, now - reported[u]});
      reported[u] = now;
    }
  }
  return log;
}

Twist2 mixed_motion(double t) {
  return {{0.2 + 0.15 * std::sin(0.6 * t), 0.2 * std::cos(0.45 * t + 0.3)},
          0.9 * std::sin(0.35 * t + 0.2) + 0.1};
}

SensorArray skewed_array() {
  std::vector<SensorMount> m(4);
  m[0].position = {0.09, 0.02};
  m[0].yaw = 0.3;
  m[0].scale = {1.03, 0.97};
  m[1].position = {-0.01, 0.1};
  m[1].yaw = 1.9;
  m[1].mirrored = true;
  m[1].cpi = 1600;
  m[2].position = {-0.08, -0.05};
  m[2].yaw = -2.5;
  m[2].scale = {0.95, 1.02};
  m[3].position = {0.02, -0.095};
  m[3].yaw = -0.7;
  m[3].cpi = 400;
  return SensorArray(m);
}

void write_log(const SynthLog& log, const SensorArray& array, const std::vector<std::string>& names,
               const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  {
    std::ofstream mice(dir / "mice.csv");
    mice << "# synthesised, noise-free; counts in each sensor's own frame\n";
    mice << "t,sensor,dx,dy\n";
    char line[128];
    for (const auto& r : log.rows) {
      std::snprintf(line, sizeof line, "%.6f,%s,%.0f,%.0f\n", r.t,
                    names[static_cast<std::size_t>(r.sensor)].c_str(), r.counts.x(), r.counts.y());
      mice << line;
    }
  }
  {
    std::ofstream truth(dir / "truth.csv");
    truth << "t,x,y,theta\n";
    char line[128];
    for (const auto& s : log.truth) {
      std::snprintf(line, sizeof line, "%.6f,%.9f,%.9f,%.9f\n", s.t, s.pose.t.x(), s.pose.t.y(),
                    s.pose.theta);
      truth << line;
    }
  }
  io::RobotConfig config;
  config.names = names;
  config.array = array;
  io::write_config(config, dir / "robot.yaml");
}

namespace {

/// Removes every scratch directory when the test program ends, so that the
/// tests that keep theirs until the end (to show a failure) leave nothing.
struct ScratchDirs {
  std::vector<std::filesystem::path> made;
  ~ScratchDirs() {
    for (const auto& dir : made) {
      std::error_code ignored;
      std::filesystem::remove_all(dir, ignored);
    }
  }
};

}  // namespace

std::filesystem::path scratch_dir(const std::string& tag) {
  static std::mt19937_64 rng(std::random_device{}());
  static ScratchDirs dirs;
  const auto dir = std::filesystem::temp_directory_path() /
                   ("moa-test-" + tag + "-" + std::to_string(rng() % 1000000000ULL));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  dirs.made.push_back(dir);
  return dir;
}

}  // namespace moa::test
