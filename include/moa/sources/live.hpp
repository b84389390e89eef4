// What the live readers (evdev mice, serial microcontroller) share: how a
// blocking next() is stopped, how the caller gets control back while no
// data comes (a status line), and where warnings go. Live readers never
// print; they report through these hooks.
#pragma once

#include <functional>
#include <string>

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

}  // namespace moa::io
