// Runs a scenario: frame by frame, the motion, every sensor, the wheels and
// the camera, handing log records to a sink (files: log_writer.hpp; memory:
// SimLog for experiments).
//
// Clock: frame k covers [k h, (k+1) h], h = 1 / frame_rate, and every time
// is computed as (frame index) / frame_rate so that it is the correctly
// rounded value (0.01, not 0.010000000000000002). Each sensor reports a zero
// row at t = 0 and then one row every K frames; truth.csv has a row at t = 0,
// one every max(1, floor(frame_rate / truth_rate)) frames and one at the end;
// wheels.csv and imu.csv one every round(frame_rate / rate) frames (the last
// interval may be shorter); the camera one fix every round(frame_rate / rate) frames from
// t = 0. Those are the true times; a row is written at its stamp, the true
// time plus its stream's latency and jitter (clock.hpp), and mice.csv's rows
// are in the order of their stamps (ties: config order).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <vector>

#include "moa/core/se2.hpp"
#include "moa/sim/camera.hpp"
#include "moa/sim/optical.hpp"
#include "moa/sim/scenario.hpp"

namespace moa::sim {

/// One mice.csv row and its faults.csv twin.
struct MiceRecord {
  double t = 0.0;  ///< s, the stamp: the interval's end plus the sensor's latency and jitter
  int sensor = 0;  ///< index in the config
  SensorRowOut row;
  double end = 0.0;  ///< s, the true end of the row's interval
};
struct WheelRecord {
  double t = 0.0;  ///< s, the stamp: the interval's end plus the wheels' latency and jitter
  Twist2 twist;
};
struct ImuRecord {
  double t = 0.0;          ///< s, stamped (the interval's end plus the gyro's latency)
  double gz = 0.0;         ///< rad/s
  bool saturated = false;  ///< a frame or the row read the full scale
  bool faulty = false;     ///< saturated, stuck, or after a bias step (imu.csv's `faults`)
};
struct TruthRecord {
  double t = 0.0;
  Pose2 pose;
  Twist2 twist;  ///< over the frame that ends at t (zero at t = 0)
};

class LogSink {
 public:
  virtual ~LogSink() = default;
  virtual void mice(const MiceRecord& record) = 0;
  virtual void wheels(const WheelRecord& record) = 0;
  virtual void imu(const ImuRecord& record) = 0;
  virtual void camera(const CameraFix& fix) = 0;
  virtual void truth(const TruthRecord& record) = 0;
};

/// A whole run in memory.
struct SimLog {
  std::vector<MiceRecord> mice;  ///< stamp order, sensors in config order within a stamp
  std::vector<WheelRecord> wheels;
  std::vector<ImuRecord> imu;
  std::vector<CameraFix> camera;  ///< the fixes kept (not dropped)
  std::vector<TruthRecord> truth;
};

/// Called now and then with the fraction of the run done (0..1).
using Progress = std::function<void(double)>;

/// Simulates `scenario` with `seed`; same seed, same records.
void simulate(const Scenario& scenario, std::uint64_t seed, LogSink& sink,
              const Progress& progress = {});
SimLog simulate(const Scenario& scenario, std::uint64_t seed);

}  // namespace moa::sim
