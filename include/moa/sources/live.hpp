// What the live readers (evdev mice, serial microcontroller) share: how a
// blocking next() is stopped, how the caller gets control back while no
// data comes (a status line), and where warnings go. Live readers never
// print; they report through these hooks.
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace moa::io {

struct LiveHooks {
  /// Polled at least every `tick_period` s while waiting for data; true
  /// ends the stream (next() returns nullopt). Empty: never stops.
  std::function<bool()> stop;
  /// Called about every `tick_period` s, data or not.
  std::function<void()> tick;
  /// One line, no newline: a condition the run survives (a device lost,
  /// frames dropped). Empty: warnings are discarded.
  std::function<void(const std::string&)> warn;
  /// Polled with every tick while a replay is due to hand out a row: while
  /// true, the replay waits (ticking) and its clock stands still, so that no
  /// data passes while the user is asked something (the guided wizard).
  /// Devices cannot wait: their data flows on. Empty: never holds.
  std::function<bool()> hold;
  double tick_period = 0.1;  ///< s

  bool should_stop() const { return stop && stop(); }
  bool held() const { return hold && hold(); }
  void warning(const std::string& text) const {
    if (warn) warn(text);
  }
};

/// A device's z gyro over one of its windows (a serial board's DATA window,
/// an OTOS unit's poll interval).
struct GyroSample {
  double t = 0.0;          ///< s, the end of the window, on its device's row clock
  double gz = 0.0;         ///< rad/s, mean over the window, counter-clockwise about the chip's z
  bool saturated = false;  ///< a sample of the window was at full scale: gz is too small
};

/// A live reader that also has a gyro (the serial board, an OTOS unit):
/// `moa live` merges its samples in as imu rows (runs/live_source.hpp).
class GyroStream {
 public:
  virtual ~GyroStream() = default;
  /// The samples decoded since the last call, in time order. When the
  /// reader's next() hands out a row, the sample of its window, if any, is
  /// here already.
  virtual std::vector<GyroSample> take_gyro() = 0;
};

}  // namespace moa::io
