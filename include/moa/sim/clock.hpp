// When a simulated row is stamped: its stream's latency and jitter.
//
// One convention for every stream (docs/formats/config.md, "Latencies"): a
// row's stamp minus the true time of what it reports (the end of the
// interval its counts or twist cover; a camera fix's capture) is the
// stream's latency, here plus a jitter:
//   stamp = t_true + latency + u,   u ~ U[-jitter/2, +jitter/2],
// u independent per row (mean latency, variance jitter^2 / 12). A stream's
// stamps stay increasing: the scenario refuses a jitter of a row period or
// more, and a stamp that would still not be after the stream's previous one
// (a last, shorter wheel interval) is put just after it (the next double).
// With latency 0 and jitter 0 the stamp is t_true itself (not a sum), so
// such a run writes the same bytes as before stamps existed.
#pragma once

#include <cstdint>
#include <optional>

#include "moa/sim/random.hpp"

namespace moa::sim {

struct StreamTiming {
  double latency = 0.0;  ///< s, stamp minus the true time (mean)
  double jitter = 0.0;   ///< s, width of the uniform spread of the stamps
};

/// Sensor frames between rows of a stream at `rate` rows/s: round(frame_rate
/// / rate), at least 1. Every periodic stream of a run (wheels, imu, camera)
/// is on this grid; a stream's row period is this times 1 / frame_rate.
std::int64_t frames_per_row(double frame_rate, double rate);

class StreamClock {
 public:
  /// The jitter's draws come from their own stream (`stream`, `index`), so
  /// that a jitter leaves the run's noise unchanged.
  StreamClock(const StreamTiming& timing, std::uint64_t seed, Stream stream, int index = 0)
      : timing_(timing), rng_(seed, stream, index) {}

  /// The stamp of a row whose true time is `t` (s).
  double stamp(double t);

 private:
  StreamTiming timing_;
  Rng rng_;
  std::optional<double> last_;
};

}  // namespace moa::sim
