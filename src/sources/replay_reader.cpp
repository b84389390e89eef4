#include "moa/sources/replay_reader.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <thread>

#include "moa/formats/error.hpp"

namespace moa::io {

OptionCheck ReplayOptions::validate() const {
  return OptionsCheck()
      .positive("speed", speed)
      .closed("speed", speed, kMinSpeed, kMaxSpeed)
      .result();
}

namespace {
const ReplayOptions& checked(const ReplayOptions& options) {
  if (const auto e = options.validate()) throw Error(fmt::format("replay: {}", e->message()));
  return options;
}
}  // namespace

ReplayReader::ReplayReader(const std::filesystem::path& log, const RobotConfig& config,
                           const ReplayOptions& options, LiveHooks hooks)
    : reader_(log, config), options_(checked(options)), hooks_(std::move(hooks)) {}

ReplayReader::~ReplayReader() = default;

double ReplayReader::start_time() {
  if (!t0_) {
    t0_ = reader_.start_time();
    started_ = std::chrono::steady_clock::now();
    last_tick_ = started_;
  }
  return *t0_;
}

std::optional<SensorRow> ReplayReader::next() {
  using Clock = std::chrono::steady_clock;
  const double t0 = start_time();
  if (hooks_.should_stop()) return std::nullopt;
  auto row = reader_.next();
  if (!row) return std::nullopt;
  // Wall seconds from the start, clamped to 0..1e9 s (32 years) before the
  // cast to the clock's integer count: its 2^63 ns are 292 years, and a
  // row's time or the speed beyond their bounds must not overflow it.
  const double wall = std::clamp((row->t - t0) / options_.speed, 0.0, 1e9);
  auto due = started_ + std::chrono::duration_cast<Clock::duration>(
                            std::chrono::duration<double>(std::isnan(wall) ? 0.0 : wall));
  const auto tick = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(std::max(hooks_.tick_period, 1e-3)));
  for (;;) {
    const auto now = Clock::now();
    if (hooks_.tick && now - last_tick_ >= tick) {
      last_tick_ = now;
      hooks_.tick();
    }
    if (hooks_.should_stop()) return std::nullopt;
    if (hooks_.held()) {
      // The replay's clock stands still while held: the rows after come
      // that much later.
      std::this_thread::sleep_until(now + tick);
      const auto waited = Clock::now() - now;
      started_ += waited;
      due += waited;
      continue;
    }
    if (now >= due) break;
    std::this_thread::sleep_until(std::min(due, last_tick_ + tick));
  }
  ++rows_;
  return row;
}

}  // namespace moa::io
