// Linux evdev mice (/dev/input/event*) as a FrameSource.
//
// Each device yields struct input_event records. REL_X and REL_Y are summed
// per frame (up to EV_SYN/SYN_REPORT) into one row (dx, dy) of raw counts,
// +REL_Y "down the screen"; the mounting in the robot config maps them. A
// mouse reports only while it moves, so a silent device means no motion
// (log format v1).
//
// Devices: opened non-blocking, checked to be input devices with relative
// X/Y (EVIOCGVERSION, EVIOCGBIT), switched to CLOCK_MONOTONIC timestamps
// (EVIOCSCLOCKID) so that all devices share one clock, and grabbed
// (EVIOCGRAB) so the desktop cursor does not follow the robot. One poll(2)
// waits on all of them.
//
// EV_SYN/SYN_DROPPED (the kernel's queue overflowed, events were lost): a
// warning and a count. Relative axes carry no state to query back, so
// resynchronising is only that; the counts that follow are real motion and
// are kept. A device that fails (unplugged: ENODEV, POLLHUP, POLLERR) is
// reported, closed, and looked for again at its path every `reopen_period`
// (by-path names survive a replug); the run goes on with the others.
//
// Row times: seconds after start_time's origin, i.e. the device clock
// (CLOCK_MONOTONIC) minus the clock at construction (or minus
// EvdevOptions::origin). Frames of different devices are merged in time;
// a frame that arrives stamped earlier than one already returned is moved
// to that time (counts kept) and counted in `reordered`.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "moa/formats/log.hpp"
#include "moa/sources/live.hpp"

namespace moa::io {

/// One motion frame of one device.
struct EvdevFrame {
  std::int64_t time_us = 0;  ///< the SYN_REPORT's timestamp, microseconds
  std::int64_t dx = 0;       ///< sum of REL_X
  std::int64_t dy = 0;       ///< sum of REL_Y
};

/// Raw struct input_event bytes (as read(2) gives them, in any pieces) to
/// motion frames. No I/O: testable with bytes from a pipe or a file.
class EvdevDecoder {
 public:
  struct Stats {
    std::uint64_t events = 0;   ///< whole input_event records
    std::uint64_t frames = 0;   ///< frames with motion returned
    std::uint64_t dropped = 0;  ///< EV_SYN/SYN_DROPPED events
    std::int64_t sum_dx = 0;    ///< every REL_X value seen
    std::int64_t sum_dy = 0;    ///< every REL_Y value seen
  };

  /// Size of one struct input_event on this platform.
  static std::size_t event_size();
  /// Bound of |EvdevFrame::time_us|: 2^62 us, about 146 000 years.
  static constexpr std::int64_t kMaxEventTimeUs = std::int64_t{1} << 62;
  /// An event's time in microseconds, its seconds clamped to
  /// +-(kMaxEventTimeUs / 10^6 - 1) and its microseconds to +-999 999:
  /// never overflows, whatever the bytes held.
  static std::int64_t event_time_us(std::int64_t sec, std::int64_t usec);

  /// Consumes `bytes`; appends each completed frame with motion to `out`.
  /// A record split across calls is completed by the next call.
  void feed(std::span<const std::uint8_t> bytes, std::vector<EvdevFrame>& out);
  /// Bytes of an incomplete record held back.
  std::size_t pending_bytes() const { return partial_size_; }
  /// Motion summed since the last SYN_REPORT (a frame not yet complete).
  bool in_frame() const { return motion_; }
  const Stats& stats() const { return stats_; }

 private:
  void event(std::int64_t time_us, std::uint16_t type, std::uint16_t code, std::int32_t value,
             std::vector<EvdevFrame>& out);

  std::uint8_t partial_[64] = {};
  std::size_t partial_size_ = 0;
  EvdevFrame frame_;
  bool motion_ = false;
  Stats stats_;
};

struct EvdevDevice {
  std::string name;            ///< sensor name, for messages
  std::filesystem::path path;  ///< e.g. /dev/input/by-path/...-event-mouse
  int sensor = 0;              ///< row.sensor of its rows (index in the config)
};

struct EvdevOptions {
  bool grab = true;  ///< EVIOCGRAB: the desktop does not see the mice
  /// Accept paths that are not input devices (FIFOs, files of recorded
  /// input_event bytes): no ioctls then. For tests and captured streams.
  bool accept_raw_streams = false;
  /// s; a lost device is looked for this often. 0: never; the stream ends
  /// when no device is left.
  double reopen_period = 1.0;
  /// Device-clock time (s) that rows are relative to; empty: CLOCK_MONOTONIC
  /// at construction.
  std::optional<double> origin;
};

class EvdevReader : public FrameSource {
 public:
  struct DeviceStatus {
    bool alive = false;
    std::uint64_t frames = 0;
    std::uint64_t dropped = 0;  ///< SYN_DROPPED seen
    std::uint64_t lost = 0;     ///< times the device went away
    std::string device_name;    ///< EVIOCGNAME, empty for raw streams
  };

  /// Opens every device; throws io::Error "PATH: why" if one cannot be used
  /// (missing, permission, not a mouse).
  EvdevReader(const std::vector<EvdevDevice>& devices, const EvdevOptions& options,
              LiveHooks hooks);
  ~EvdevReader() override;
  /// 0: rows are relative to the origin.
  double start_time() override;
  /// Blocks until a frame, the stop hook, or (reopen_period 0) every
  /// device gone.
  std::optional<SensorRow> next() override;

  const DeviceStatus& status(int device) const;
  int alive() const;
  std::uint64_t reordered() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace moa::io
