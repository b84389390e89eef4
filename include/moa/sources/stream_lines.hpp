// The robot's own streams while live: wheel twists, gyro rates and camera
// fixes from the robot's program, one line each, on standard input, a FIFO,
// a file or a UDP port (`moa live --streams PATH|-|udp:[HOST:]PORT`;
// docs/formats/stream-lines.md).
//
// A line is CSV: the stream's name, then the columns of its log file
// (docs/formats/log.md) in their order:
//   wheels,t,vx,vy,omega          twist in the robot frame (m/s, m/s, rad/s),
//                                 averaged over the interval ending at t
//   imu,t,gz                      yaw rate about z up (rad/s, counter-
//                                 clockwise), averaged over the interval
//                                 ending at t
//   camera,t,x,y[,theta[,sx,sy]]  robot centre in the world frame (m), its
//                                 heading (rad) and standard deviations (m)
// or a flat JSON object with the same names as keys and "stream" for the
// stream: {"stream":"wheels","t":1.5,"vx":0.2,"vy":0,"omega":0.1}.
// t (s) may be empty (absent or null in JSON): the line is then stamped at
// its arrival. theta may be empty (no heading); sx and sy come together.
// Blank lines and lines starting with '#' are skipped. Over UDP a datagram
// holds one line or several, its end ending the last.
//
// A given t is on the live source's clock (StreamClock::kSource), or on this
// machine's monotonic clock (kMonotonic: CLOCK_MONOTONIC, as Python's
// time.monotonic() or C++'s std::chrono::steady_clock), from which the run
// maps it onto the source's clock as it maps arrivals.
//
// A bad line is counted by kind and never stops the run; the first line of
// each kind is kept for the message. A given t beyond +-kMaxTime (4e9 s, the
// logs' bound) is bad, and so is one more than kMaxStreamLead ahead of the
// source's clock at its arrival (once the run has told the reader that
// clock): it is never taken as the stream's time. At most kMaxQueuedLines
// good lines wait for the run; beyond that, lines are dropped and counted
// (a file waits instead: it is read as the run takes its lines).
#pragma once

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include "moa/core/odometry.hpp"
#include "moa/formats/log.hpp"

namespace moa::io {

/// Which clock a line's t is on.
enum class StreamClock : std::uint8_t {
  kSource,     ///< the live source's (a replayed log's, the board's)
  kMonotonic,  ///< this machine's CLOCK_MONOTONIC (std::chrono::steady_clock), s
};

/// One good line: a wheel row, a camera fix or a gyro rate; `stamped` false
/// when its t is to be mapped from `arrival` (t empty: the line's arrival;
/// StreamClock::kMonotonic: the time it gives).
struct StreamRow {
  std::variant<WheelRow, CameraFix, ImuRow> row;
  bool stamped = false;
  std::chrono::steady_clock::time_point arrival;
};

enum class StreamLineError : std::uint8_t {
  kUnknownStream,   ///< the stream is not "wheels", "imu" or "camera"
  kFieldCount,      ///< too few or too many fields for the stream
  kNotANumber,      ///< a field that is not a finite number (or empty where it may not be)
  kTimeBackwards,   ///< t earlier than the stream's previous line's
  kTooLong,         ///< longer than kMaxStreamLine bytes
  kBadJson,         ///< starts with '{' but is no flat JSON object of known keys
  kTimeOutOfRange,  ///< |t| > kMaxTime (4e9 s), the bound of every log's times
  kTimeAhead,       ///< t more than kMaxStreamLead ahead of the source's clock at its arrival
  kImplausible,     ///< a value beyond core/plausible.hpp's bounds (a corrupt value)
};
inline constexpr std::size_t kStreamLineErrors = 9;
/// "unknown stream (not wheels, imu or camera)", ...
const char* describe(StreamLineError error);

/// Longest line taken (bytes, without the newline); longer ones are bad.
inline constexpr std::size_t kMaxStreamLine = 1024;

/// s of the source's clock: how far ahead of it a line's t may be when the
/// line arrives. A robot's program stamps its lines at most a latency
/// ahead; a line further ahead (a clock of its own, a typo) would be held
/// for a mice row that never comes and take every later line with it.
inline constexpr double kMaxStreamLead = 60.0;

/// Good lines that may wait for the run to take them (StreamLineReader).
inline constexpr std::size_t kMaxQueuedLines = 65536;

/// Bytes without a line end after which an input is taken for no stream of
/// lines (/dev/zero, a binary file) and read no further.
inline constexpr std::size_t kMaxStreamUnended = std::size_t{1} << 20;

/// The live source's clock as the run last saw it: the time `t` (s) of a
/// mice row received at `arrival`, running at `speed` seconds of the source
/// per second of wall time (a replay's --speed; 1 for devices).
struct SourceClock {
  double t = 0.0;
  std::chrono::steady_clock::time_point arrival;
  double speed = 1.0;
};

/// Parses one line (without its newline): the row; std::monostate for a
/// blank or comment line; the error for a bad one. Times are not checked for
/// order here (StreamLineReader does, per stream).
std::variant<std::monostate, StreamRow, StreamLineError> parse_stream_line(std::string_view line);

/// Reads lines from standard input, a FIFO, a file or a UDP port on a thread
/// of its own, parses them and queues the good ones, stamped with
/// their arrival. Never blocks its consumer; stops at end of file, at
/// destruction or stop().
class StreamLineReader {
 public:
  struct Stats {
    std::size_t wheels = 0, fixes = 0, imu = 0;          ///< good lines
    std::array<std::size_t, kStreamLineErrors> bad{};    ///< bad lines by kind
    std::array<std::string, kStreamLineErrors> first{};  ///< the first bad line of each kind
    /// Good lines dropped: kMaxQueuedLines were waiting for the run (a
    /// burst or a flood faster than the run takes them).
    std::size_t overflow = 0;
    /// The input sent kMaxStreamUnended bytes without a line end: a line
    /// too long was counted, and nothing more is read.
    bool not_lines = false;
    std::size_t bad_total() const;
  };

  /// `path`: a file or FIFO, "-" for standard input, or "udp:[HOST:]PORT"
  /// (HOST defaults to 127.0.0.1) to listen on. Throws io::Error when it
  /// cannot be opened (a FIFO is opened on the thread: the run does not
  /// wait for its writer) or the port cannot be bound. `source`: the
  /// source's clock from the start (set_source_clock), so that no line is
  /// read before it is known.
  explicit StreamLineReader(const std::string& path, StreamClock clock = StreamClock::kSource,
                            std::optional<SourceClock> source = std::nullopt);
  ~StreamLineReader();
  StreamLineReader(const StreamLineReader&) = delete;
  StreamLineReader& operator=(const StreamLineReader&) = delete;

  /// The good lines arrived since the last call, in arrival order.
  void take(std::vector<StreamRow>& out);
  /// The source's clock, against which a line's t is checked from now on
  /// (kTimeAhead); until the first call, no t is too far ahead.
  void set_source_clock(const SourceClock& clock);
  /// A bad line of a kind not seen before, once each: (kind, the line).
  std::optional<std::pair<StreamLineError, std::string>> take_new_error();
  Stats stats() const;
  void stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace moa::io
