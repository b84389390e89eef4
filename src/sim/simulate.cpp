#include "moa/sim/simulate.hpp"

#include <algorithm>
#include <cmath>

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

std::int64_t frames_per(double frame_rate, double rate) {
  return std::max<std::int64_t>(1, std::llround(frame_rate / rate));
}

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
  const std::int64_t wheel_every = frames_per(fps, scenario.drive.rate);
  const std::int64_t imu_every = frames_per(fps, scenario.imu.rate);
  const std::int64_t camera_every = frames_per(fps, scenario.camera.rate);
  const auto time = [fps](std::int64_t frame) { return static_cast<double>(frame) / fps; };

  std::vector<OpticalSensor> sensors;
  const int n = scenario.truth.array.size();
  sensors.reserve(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    sensors.emplace_back(scenario.truth.array[i], model,
                         scenario.faults[static_cast<std::size_t>(i)], seed, i);
  }
  const bool has_wheels = scenario.drive.type != DriveType::kNone;
  WheelOdometry wheels(scenario.drive, seed);
  Camera camera(scenario.camera, seed);
  SimGyro gyro(scenario.imu, seed);
  std::int64_t last_imu_frame = 0;
  MotionStepper stepper(scenario.motion);

  for (int i = 0; i < n; ++i)
    sink.mice({0.0, i, sensors[static_cast<std::size_t>(i)].initial_row()});
  sink.truth({0.0, stepper.pose(), {}});
  if (scenario.camera.enabled) sink.camera(camera.capture(0.0, stepper.pose()));

  std::int64_t last_wheel_frame = 0;
  const std::int64_t progress_every = std::max<std::int64_t>(1, frames / 100);
  for (std::int64_t k = 0; k < frames; ++k) {
    const double t0 = time(k);
    const double t1 = time(k + 1);
    const double h = t1 - t0;
    const MotionStepper::Step step = stepper.advance(t0, t1);
    for (int i = 0; i < n; ++i) {
      if (auto row = sensors[static_cast<std::size_t>(i)].frame(step.twist, t0, h)) {
        sink.mice({t1, i, *row});
      }
    }
    if (has_wheels) {
      wheels.frame(step.twist, h);
      if ((k + 1) % wheel_every == 0 || k + 1 == frames) {
        sink.wheels({t1, wheels.take_row(t1 - time(last_wheel_frame))});
        last_wheel_frame = k + 1;
      }
    }
    if (scenario.imu.enabled) {
      gyro.frame(step.twist.omega, h);
      if ((k + 1) % imu_every == 0 || k + 1 == frames) {
        sink.imu({t1 + scenario.imu.latency, gyro.take_row(t1 - time(last_imu_frame))});
        last_imu_frame = k + 1;
      }
    }
    if ((k + 1) % truth_every == 0 || k + 1 == frames) {
      sink.truth({t1, step.pose, step.twist});
    }
    if (scenario.camera.enabled && (k + 1) % camera_every == 0) {
      sink.camera(camera.capture(t1, step.pose));
    }
    if (progress && (k + 1) % progress_every == 0) {
      progress(static_cast<double>(k + 1) / static_cast<double>(frames));
    }
  }
}

SimLog simulate(const Scenario& scenario, std::uint64_t seed) {
  SimLog log;
  MemorySink sink(log);
  simulate(scenario, seed, sink);
  return log;
}

}  // namespace moa::sim
