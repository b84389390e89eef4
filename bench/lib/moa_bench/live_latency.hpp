// `moa bench --live`: the latency of moa in a robot's loop, from a mice
// row's arrival to the pose line it completes written (docs/performance.md).
// A generated log of four sensors is replayed in real time through the path
// of `moa live --replay ... --pose-out udp:...` (ReplayReader, LiveRunSource,
// the run loop, PoseStream) to a UDP socket of this process; each step's
// latency is the steady (monotonic) clock's time after its line was sent
// minus the time its last mice row was handed over by the source. Twice:
// with a reader thread that waits for each line (every send wakes it, and
// on a busy machine the sender may then wait for a CPU), and with a reader
// that has stopped reading (the send alone).
#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace moa::bench {

struct LiveLatencyOptions {
  std::vector<double> rates{100.0, 1000.0};  ///< Hz: rows per sensor and epochs per second
  double duration = 5.0;                     ///< s of log at each rate
  std::string estimator = "consensus";       ///< ls, sekimori or consensus
  std::filesystem::path dir;                 ///< for the temporary logs (system temp if empty)
};

struct LiveLatency {
  double rate_hz = 0.0;
  bool reader_reading = true;  ///< a reader woken by every line; false: a stalled one
  std::size_t steps = 0;       ///< steps measured (those completed by a mice row)
  double p50_s = 0.0, p99_s = 0.0, max_s = 0.0;
  std::size_t lines_received = 0;  ///< pose lines the socket got
  std::size_t lines_dropped = 0;   ///< pose lines the stream counted as dropped
};

/// One result per rate, in order, with the reader reading, then the same
/// with it stalled. `progress` gets a line per stage.
/// Throws std::invalid_argument for an estimator it cannot run on the log.
std::vector<LiveLatency> run_live_latency_bench(
    const LiveLatencyOptions& options,
    const std::function<void(const std::string&)>& progress = {});

}  // namespace moa::bench
