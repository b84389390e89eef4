#include "moa/sim/simulate.hpp"

#include <algorithm>
#include <cmath>
#include <deque>

#include "moa/sim/gyro.hpp"
#include "moa/sim/wheels.hpp"

namespace moa::sim {
namespace {

class MemorySink : public LogSink {
 public:
  explicit MemorySink(SimLog& log) : log_(log) {}
  void mice(const MiceRecord& r) override { log_.mice.push_back(r); }
  void wheels(const WheelRecord& r) override { log_.wheels.push_back(r); }
  void imu(const ImuRecord& r) override { log_.imu.push_back(r); }
  void camera(const CameraFix& f) override { log_.camera.push_back(f); }
  void truth(const TruthRecord& r) override { log_.truth.push_back(r); }

 private:
  SimLog& log_;
};

// mice.csv in the order of the stamps. A sensor's stamps increase
// (clock.hpp), so once every sensor has a row waiting, the smallest waiting
// stamp (ties: config order) is final; rows wait at most the spread of the
// sensors' latencies plus a jitter. With equal latencies and no jitter the
// rows leave in the order they were made.
class MiceMerger {
 public:
  MiceMerger(int sensors, LogSink& sink)
      : pending_(static_cast<std::size_t>(sensors)), sink_(sink) {}
  void push(const MiceRecord& record) {
    pending_[static_cast<std::size_t>(record.sensor)].push_back(record);
    drain(false);
  }
  void finish() { drain(true); }

 private:
  void drain(bool all) {
    for (;;) {
      std::deque<MiceRecord>* best = nullptr;
      for (auto& queue : pending_) {
        if (queue.empty()) {
          if (!all) return;
          continue;
        }
        if (best == nullptr || queue.front().t < best->front().t) best = &queue;
      }
      if (best == nullptr) return;
      sink_.mice(best->front());
      best->pop_front();
    }
  }
  std::vector<std::deque<MiceRecord>> pending_;
  LogSink& sink_;
};

}  // namespace

void simulate(const Scenario& scenario, std::uint64_t seed, LogSink& sink,
              const Progress& progress) {
  const SensorModel& model = scenario.sensor_model;
  const double fps = model.frame_rate;
  const std::int64_t frames = scenario.frame_count();
  // The tolerance keeps a rate that divides the frame rate (6400 / 533.33...)
  // from losing a frame to rounding.
  const auto truth_every = std::max<std::int64_t>(
      1, static_cast<std::int64_t>(std::floor(fps / scenario.truth_rate + 1e-9)));
  const std::int64_t wheel_every = frames_per_row(fps, scenario.drive.rate);
  const std::int64_t imu_every = frames_per_row(fps, scenario.imu.rate);
  const std::int64_t camera_every = frames_per_row(fps, scenario.camera.rate);
  const auto time = [fps](std::int64_t frame) { return static_cast<double>(frame) / fps; };

  std::vector<OpticalSensor> sensors;
  std::vector<StreamClock> clocks;
  const int n = scenario.truth.array.size();
  sensors.reserve(static_cast<std::size_t>(n));
  clocks.reserve(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const auto u = static_cast<std::size_t>(i);
    sensors.emplace_back(scenario.truth.array[i], model, scenario.faults[u], seed, i);
    const StreamTiming timing =
        u < scenario.sensor_timing.size() ? scenario.sensor_timing[u] : StreamTiming{};
    clocks.emplace_back(timing, seed, Stream::kSensorClock, i);
  }
  MiceMerger mice(n, sink);
  const auto mice_row = [&](double end, int i, const SensorRowOut& row) {
    mice.push({clocks[static_cast<std::size_t>(i)].stamp(end), i, row, end});
  };
  StreamClock wheel_clock(scenario.wheel_timing, seed, Stream::kWheelClock);
  const bool has_wheels = scenario.drive.type != DriveType::kNone;
  WheelOdometry wheels(scenario.drive, seed);
  Camera camera(scenario.camera, seed);
  SimGyro gyro(scenario.imu, seed);
  std::int64_t last_imu_frame = 0;
  MotionStepper stepper(scenario.motion);

  for (int i = 0; i < n; ++i) mice_row(0.0, i, sensors[static_cast<std::size_t>(i)].initial_row());
  sink.truth({0.0, stepper.pose(), {}});
  if (scenario.camera.enabled) {
    if (const auto fix = camera.capture(0.0, stepper.pose())) sink.camera(*fix);
  }

  std::int64_t last_wheel_frame = 0;
  const std::int64_t progress_every = std::max<std::int64_t>(1, frames / 100);
  for (std::int64_t k = 0; k < frames; ++k) {
    const double t0 = time(k);
    const double t1 = time(k + 1);
    const double h = t1 - t0;
    const MotionStepper::Step step = stepper.advance(t0, t1);
    for (int i = 0; i < n; ++i) {
      if (auto row = sensors[static_cast<std::size_t>(i)].frame(step.twist, t0, h)) {
        mice_row(t1, i, *row);
      }
    }
    if (has_wheels) {
      wheels.frame(step.twist, h);
      if ((k + 1) % wheel_every == 0 || k + 1 == frames) {
        sink.wheels({wheel_clock.stamp(t1), wheels.take_row(t1 - time(last_wheel_frame))});
        last_wheel_frame = k + 1;
      }
    }
    if (scenario.imu.enabled) {
      gyro.frame(step.twist.omega, h);
      if ((k + 1) % imu_every == 0 || k + 1 == frames) {
        const double gz = gyro.take_row(t1 - time(last_imu_frame));
        sink.imu({t1 + scenario.imu.latency, gz, gyro.saturated(), gyro.faulty()});
        last_imu_frame = k + 1;
      }
    }
    if ((k + 1) % truth_every == 0 || k + 1 == frames) {
      sink.truth({t1, step.pose, step.twist});
    }
    if (scenario.camera.enabled && (k + 1) % camera_every == 0) {
      if (const auto fix = camera.capture(t1, step.pose)) sink.camera(*fix);
    }
    if (progress && (k + 1) % progress_every == 0) {
      progress(static_cast<double>(k + 1) / static_cast<double>(frames));
    }
  }
  mice.finish();
}

SimLog simulate(const Scenario& scenario, std::uint64_t seed) {
  SimLog log;
  MemorySink sink(log);
  simulate(scenario, seed, sink);
  return log;
}

}  // namespace moa::sim
