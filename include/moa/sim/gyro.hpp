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
#pragma once

#include <cstdint>

#include "moa/sim/random.hpp"

namespace moa::sim {

/// The scenario's `imu:` block (docs/simulator.md).
struct GyroSpec {
  bool enabled = false;
  double rate = 100.0;            ///< rows per second
  double scale = 1.0;             ///< k, true reading per rad/s
  double bias = 0.0;              ///< rad/s, at t = 0
  double bias_walk = 0.0;         ///< rad/s/sqrt(s)
  double noise_density = 1.5e-4;  ///< rad/s/sqrt(Hz)
  double max_rate = 8.7;          ///< rad/s, full scale
  double latency = 0.0;           ///< s, a row's stamp after its interval's end
};

class SimGyro {
 public:
  SimGyro(const GyroSpec& spec, std::uint64_t seed) : spec_(spec), rng_(seed, Stream::kGyro) {}
  /// One frame of h s turning at omega (rad/s).
  void frame(double omega, double h);
  /// The row over the frames since the previous one, dt s long (rad/s).
  double take_row(double dt);

 private:
  double clamp(double r) const;
  GyroSpec spec_;
  Rng rng_;
  double bias_ = spec_.bias;
  double sum_ = 0.0;  ///< rad, integral of the reading over the row
};

}  // namespace moa::sim
