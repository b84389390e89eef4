// A recorded log played back at the pace it was recorded, as a live
// FrameSource: `moa live --replay DIR` and `moa calibrate --guided --live
// --replay DIR` run demos and tests through the same path as USB mice and
// the serial board, without hardware.
//
// Row k of mice.csv (time t_k) is handed out no earlier than wall time
// start + (t_k - t0) / speed, t0 the log's start time and start the moment
// start_time() is first called. While it waits, the reader calls
// LiveHooks::tick every tick_period and stops when LiveHooks::stop says so,
// as the device readers do; while LiveHooks::hold says so, it waits with its
// clock stopped (the rows after come that much later). A caller slower than the log does not skip
// rows: it catches up (rows come back-to-back until it is on time again).
#pragma once

#include <chrono>
#include <filesystem>
#include <memory>
#include <optional>

#include "moa/core/options_check.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/log.hpp"
#include "moa/sources/live.hpp"

namespace moa::io {

struct ReplayOptions {
  /// The playback speeds allowed: a day's log (kMaxSpan) at the slowest
  /// plays in 2.7 years of wall time, still a count of nanoseconds.
  static constexpr double kMinSpeed = 1e-3;
  static constexpr double kMaxSpeed = 1e6;
  /// Playback speed: 1 is real time, 2 twice as fast; within
  /// [kMinSpeed, kMaxSpeed].
  double speed = 1.0;
  /// nullopt when usable, else "speed: must be ..., is ..." (core/options_check.hpp).
  OptionCheck validate() const;
};

class ReplayReader : public FrameSource {
 public:
  /// Opens the log (directory or its mice.csv, sensors resolved against
  /// `config`); throws io::Error for a bad log or invalid options.
  ReplayReader(const std::filesystem::path& log, const RobotConfig& config,
               const ReplayOptions& options, LiveHooks hooks);
  ~ReplayReader() override;
  double start_time() override;
  std::optional<SensorRow> next() override;

  /// Rows handed out so far.
  std::size_t rows() const { return rows_; }

 private:
  MiceReader reader_;
  ReplayOptions options_;
  LiveHooks hooks_;
  std::optional<double> t0_;
  std::chrono::steady_clock::time_point started_;
  std::chrono::steady_clock::time_point last_tick_;
  std::size_t rows_ = 0;
};

}  // namespace moa::io
