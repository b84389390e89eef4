#include "moa_bench/bench_log.hpp"

#include <fmt/core.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <vector>

#include "moa/core/sensor.hpp"
#include "moa/formats/mice_writer.hpp"

namespace moa::bench {
namespace fs = std::filesystem;

ScratchDir::ScratchDir(const fs::path& parent, bool keep) : keep_(keep) {
  std::random_device random;
  path_ = parent / fmt::format("moa-bench-{}-{:08x}", ::getpid(), random());
  fs::create_directories(path_);
}

ScratchDir::~ScratchDir() {
  if (keep_) return;
  std::error_code ignored;
  fs::remove_all(path_, ignored);
}

io::RobotConfig four_sensors() {
  io::RobotConfig config;
  std::vector<SensorMount> mounts(4);
  for (int i = 0; i < 4; ++i) {
    const double phi = std::numbers::pi / 4.0 + i * std::numbers::pi / 2.0;
    auto& m = mounts[static_cast<std::size_t>(i)];
    m.position = 0.1 * Eigen::Vector2d(std::cos(phi), std::sin(phi));
    m.yaw = phi;
    m.cpi = kHdns2051.cpi;
    m.max_speed = kHdns2051.max_speed;
    config.names.push_back(fmt::format("m{}", i + 1));
  }
  config.array = SensorArray(mounts);
  return config;
}

namespace {

/// A smooth drive in every direction at once, below the sensors' rated
/// speed (at most 0.25 m/s + 0.8 rad/s x 0.1 m = 0.33 m/s at a sensor).
Twist2 drive(double t) {
  const double two_pi = 2.0 * std::numbers::pi;
  return Twist2{{0.2 * std::sin(two_pi * t / 7.0), 0.15 * std::sin(two_pi * t / 11.0 + 1.0)},
                0.8 * std::sin(two_pi * t / 5.0)};
}

}  // namespace

std::size_t write_log(const io::RobotConfig& config, double duration, double row_rate,
                      const fs::path& dir) {
  io::write_config(config, dir / "robot.yaml");
  io::MiceWriter writer(dir / "mice.csv", config.names, true,
                        io::MiceWriter::Durability::kWholeOrNothing,
                        {"moa bench: synthetic drive, noise-free counts"});
  const int n = config.array.size();
  std::vector<Eigen::Vector2d> carried(static_cast<std::size_t>(n), Eigen::Vector2d::Zero());
  const auto rows = static_cast<std::int64_t>(std::llround(duration * row_rate));
  const double dt = 1.0 / row_rate;
  SensorRow row;
  row.squal = 100;
  for (std::int64_t k = 0; k <= rows; ++k) {
    row.t = static_cast<double>(k) / row_rate;
    const Twist2 x = drive(row.t - 0.5 * dt);
    for (int i = 0; i < n; ++i) {
      auto& c = carried[static_cast<std::size_t>(i)];
      if (k > 0) c += config.array[i].counts(x, dt);
      row.sensor = i;
      row.counts = c.array().round();
      c -= row.counts;
      writer.write(row);
    }
  }
  writer.commit();
  return writer.rows();
}

}  // namespace moa::bench
