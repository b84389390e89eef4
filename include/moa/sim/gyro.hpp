// A simulated z-axis MEMS gyro (imu.csv, log format v1): what an MPU-6050
// class part reports while the robot turns at omega(t).
//
// Within each sensor frame of h s the gyro reads
//   r = clamp(k omega + b(t), -max_rate, max_rate),
// k its true scale, b(t) its bias: b(0) = bias, then a random walk of
// `bias_walk` rad/s/sqrt(s) (b grows by bias_walk sqrt(h) N(0, 1) per
// frame). A row averages r over its interval of dt s and adds white noise of
// noise_density / sqrt(dt) (a noise density d in rad/s/sqrt(Hz) averaged
// over dt), clamped again (a saturated part reads its full scale). Rows come
// every round(frame_rate / rate) frames, stamped `latency` s after the end
// of the interval they cover (the part's filter and the bus).
//
// Faults (`imu: {faults: [...]}`, docs/simulator.md), by the frame's midpoint t:
//   stuck      in [start, end): every row repeats the last row before the
//              window (a register that stopped updating);
//   bias_step  from start on: b(t) gains `step` rad/s once (a warm-up or a
//              knock: the bias jumps and stays).
// Saturation is not a fault here but the model's own clamp: a turn faster
// than max_rate / scale reads the full scale.
#pragma once

#include <cstdint>
#include <vector>

#include "moa/sim/random.hpp"

namespace moa::sim {

/// The scenario's `imu:` block (docs/simulator.md).
struct GyroFault {
  enum Kind { kStuck, kBiasStep } kind = kStuck;
  double start = 0.0;  ///< s
  double end = 0.0;    ///< s, stuck: the window's end (a bias step stays)
  double step = 0.0;   ///< rad/s, bias_step
};

struct GyroSpec {
  bool enabled = false;
  double rate = 100.0;            ///< rows per second
  double scale = 1.0;             ///< k, true reading per rad/s
  double bias = 0.0;              ///< rad/s, at t = 0
  double bias_walk = 0.0;         ///< rad/s/sqrt(s)
  double noise_density = 1.5e-4;  ///< rad/s/sqrt(Hz)
  double max_rate = 8.7;          ///< rad/s, full scale
  double latency = 0.0;           ///< s, a row's stamp after its interval's end
  /// s, the true latency minus the one robot.yaml states (a robot program's
  /// stamps off by milliseconds); robot.true.yaml states the true one
  double latency_error = 0.0;
  std::vector<GyroFault> faults;
};

class SimGyro {
 public:
  SimGyro(const GyroSpec& spec, std::uint64_t seed) : spec_(spec), rng_(seed, Stream::kGyro) {}
  /// One frame of h s turning at omega (rad/s).
  void frame(double omega, double h);
  /// The row over the frames since the previous one, dt s long (rad/s).
  double take_row(double dt);
  /// Of the row last taken: a frame or the row read the full scale.
  bool saturated() const { return row_saturated_; }
  /// Of the row last taken: saturated, stuck, or after a bias step.
  bool faulty() const { return row_faulty_; }

 private:
  double clamp(double r) const;
  GyroSpec spec_;
  Rng rng_;
  double bias_ = spec_.bias;
  double sum_ = 0.0;  ///< rad, integral of the reading over the row
  double t_ = 0.0;    ///< s, the end of the last frame
  double last_row_ = 0.0;
  bool saturating_ = false;  ///< a frame of the row being made read the full scale
  bool stepped_any_ = false;
  bool row_saturated_ = false;
  bool row_faulty_ = false;
  std::vector<bool> stepped_ = std::vector<bool>(spec_.faults.size(), false);
};

}  // namespace moa::sim
