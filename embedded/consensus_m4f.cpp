// The library's odometry pipeline (moa::Odometry: synchroniser, consensus
// estimator, dead reckoning) on a Cortex-M4F, for four ADNS-3080 sensors at
// the corners of a square: the program whose flash and RAM sizes
// docs/performance.md reports. The counts come from volatile
// registers (on a board, an SPI driver's interrupt fills them), so the
// compiler cannot fold the estimator away; the pose goes out the same way.
//
// Everything lives in static storage or on the stack: the program links no
// malloc, no operator new and no exception support (CMakeLists.txt checks).
#include <array>
#include <cstdint>
#include <numbers>
#include <optional>
#include <type_traits>
#include <variant>

#include "moa/core/array.hpp"
#include "moa/core/odometry.hpp"
#include "moa/core/sensor.hpp"

namespace {

constexpr int kSensors = 4;
constexpr double kPeriod = 1e-3;  // s, one update per millisecond

// Inputs, as an acquisition interrupt would leave them.
struct SensorRegisters {
  std::int16_t dx;
  std::int16_t dy;
  std::uint8_t squal;
  std::uint8_t flags;
};
volatile SensorRegisters g_sensors[kSensors];
volatile std::uint32_t g_updates;

// Outputs: the pose (m, m, rad) and the sensors used in the last update.
volatile float g_pose[3];
volatile std::uint32_t g_used;

// In .bss, so that the RAM figure shows the pipeline's state: the library's
// Odometry (synchroniser, consensus estimator, dead reckoning), the same
// type `moa odometry` runs. Trivially destructible: nothing runs at exit.
std::optional<moa::Odometry> g_odometry;
static_assert(std::is_trivially_destructible_v<moa::Odometry>);

moa::SensorArray square_array() {
  moa::SensorMount prototype;
  prototype.cpi = moa::kAdns3080.cpi;
  prototype.max_speed = moa::kAdns3080.max_speed;
  prototype.noise = 0.002;
  return moa::regular_polygon(kSensors, 0.06, std::numbers::pi_v<moa::real> / 4, prototype);
}

}  // namespace

extern "C" [[noreturn]] void moa_m4f_main() {
  moa::OdometryOptions options;
  options.rate = 1.0 / kPeriod;
  g_odometry.emplace(square_array(), 0.0, options);
  if (g_odometry->geometry_error()) {
    for (;;) {
    }
  }
  const auto sink = [](const moa::OdometryStep& step) {
    g_pose[0] = static_cast<float>(step.pose.t.x());
    g_pose[1] = static_cast<float>(step.pose.t.y());
    g_pose[2] = static_cast<float>(step.pose.theta);
    g_used = step.estimate.estimate.used;
  };
  std::uint32_t seen = g_updates;
  double t = 0.0;
  for (;;) {
    while (g_updates == seen) {
    }
    seen = g_updates;
    t += kPeriod;
    // One row per sensor per update: every sensor reports at t, so the
    // epoch ending at t is final at once and the sink runs.
    for (int i = 0; i < kSensors; ++i) {
      const auto u = static_cast<std::size_t>(i);
      moa::SensorRow row;
      row.t = t;
      row.sensor = i;
      row.counts = moa::Vec2(static_cast<moa::real>(g_sensors[u].dx),
                             static_cast<moa::real>(g_sensors[u].dy));
      row.squal = g_sensors[u].squal;
      row.flags = g_sensors[u].flags;
      (void)g_odometry->push(row, sink);  // a refused row is dropped: no error channel here
    }
  }
}
