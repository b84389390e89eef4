// The consensus estimator and dead reckoning on a Cortex-M4F, for four
// ADNS-3080 sensors at the corners of a square: the program whose flash
// and RAM sizes docs/performance.md reports. The counts come from volatile
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
#include "moa/core/consensus.hpp"
#include "moa/core/dead_reckoner.hpp"
#include "moa/core/estimate.hpp"
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

// In .bss, so that the RAM figure shows the estimator's state. Trivially
// destructible: nothing is registered to run at exit.
std::optional<moa::ConsensusEstimator> g_estimator;
moa::DeadReckoner g_reckoner;
static_assert(std::is_trivially_destructible_v<moa::ConsensusEstimator>);
static_assert(std::is_trivially_destructible_v<moa::DeadReckoner>);

moa::SensorArray square_array() {
  moa::SensorMount prototype;
  prototype.cpi = moa::kAdns3080.cpi;
  prototype.max_speed = moa::kAdns3080.max_speed;
  prototype.noise = 0.002;
  return moa::regular_polygon(kSensors, 0.06, std::numbers::pi / 4.0, prototype);
}

moa::ArraySample read_sample(double t) {
  moa::ArraySample sample;
  sample.t = t;
  sample.dt = kPeriod;
  sample.size = kSensors;
  for (std::size_t i = 0; i < kSensors; ++i) {
    sample.counts[i] =
        Eigen::Vector2d(static_cast<double>(g_sensors[i].dx), static_cast<double>(g_sensors[i].dy));
    sample.squal[i] = g_sensors[i].squal;
    sample.flags[i] = g_sensors[i].flags;
  }
  return sample;
}

}  // namespace

extern "C" [[noreturn]] void moa_m4f_main() {
  const auto built = moa::ConsensusEstimator::create(square_array());
  const auto* estimator = std::get_if<moa::ConsensusEstimator>(&built);
  if (estimator == nullptr) {
    for (;;) {
    }
  }
  g_estimator.emplace(*estimator);

  std::uint32_t seen = g_updates;
  double t = 0.0;
  for (;;) {
    while (g_updates == seen) {
    }
    seen = g_updates;
    t += kPeriod;
    const auto out = g_estimator->estimate(read_sample(t));
    if (!out) continue;
    const moa::Pose2& pose = g_reckoner.step(out->estimate.twist, kPeriod);
    g_pose[0] = static_cast<float>(pose.t.x());
    g_pose[1] = static_cast<float>(pose.t.y());
    g_pose[2] = static_cast<float>(pose.theta);
    g_used = out->estimate.used;
  }
}
