// The robot's own streams while live: wheel twists and camera fixes from the
// robot's program, one line each, on standard input or a FIFO (`moa live
// --streams PATH|-`, docs/live.md).
//
// A line is CSV: the stream's name, then the columns of its log file
// (docs/formats/log.md) in their order:
//   wheels,t,vx,vy,omega          twist in the robot frame (m/s, m/s, rad/s),
//                                 averaged over the interval ending at t
//   camera,t,x,y[,theta[,sx,sy]]  robot centre in the world frame (m), its
//                                 heading (rad) and standard deviations (m)
// t (s, on the live source's clock) may be empty: the line is then stamped
// at its arrival. theta may be empty (no heading); sx and sy come together.
// Blank lines and lines starting with '#' are skipped.
//
// A bad line is counted by kind and never stops the run; the first line of
// each kind is kept for the message.
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

/// One good line: a wheel row or a camera fix; `stamped` false when its t
/// was empty (t then 0 until stamped at `arrival`).
struct StreamRow {
  std::variant<WheelRow, CameraFix> row;
  bool stamped = false;
  std::chrono::steady_clock::time_point arrival;
};

enum class StreamLineError : std::uint8_t {
  kUnknownStream,  ///< the first field is neither "wheels" nor "camera"
  kFieldCount,     ///< too few or too many fields for the stream
  kNotANumber,     ///< a field that is not a finite number (or empty where it may not be)
  kTimeBackwards,  ///< t earlier than the stream's previous line's
  kTooLong,        ///< longer than kMaxStreamLine bytes
};
inline constexpr std::size_t kStreamLineErrors = 5;
/// "unknown stream (not wheels or camera)", ...
const char* describe(StreamLineError error);

/// Longest line taken (bytes, without the newline); longer ones are bad.
inline constexpr std::size_t kMaxStreamLine = 1024;

/// Parses one line (without its newline): the row; std::monostate for a
/// blank or comment line; the error for a bad one. Times are not checked for
/// order here (StreamLineReader does, per stream).
std::variant<std::monostate, StreamRow, StreamLineError> parse_stream_line(std::string_view line);

/// Reads lines from a file descriptor (standard input, a FIFO, a file) on a
/// thread of its own, parses them and queues the good ones, stamped with
/// their arrival. Never blocks its consumer; stops at end of file, at
/// destruction or stop().
class StreamLineReader {
 public:
  struct Stats {
    std::size_t wheels = 0, fixes = 0;                   ///< good lines
    std::array<std::size_t, kStreamLineErrors> bad{};    ///< bad lines by kind
    std::array<std::string, kStreamLineErrors> first{};  ///< the first bad line of each kind
    std::size_t bad_total() const;
  };

  /// `path`: a file or FIFO, or "-" for standard input. Throws io::Error
  /// when it cannot be opened (a FIFO is opened on the thread: the run does
  /// not wait for its writer).
  explicit StreamLineReader(const std::string& path);
  ~StreamLineReader();
  StreamLineReader(const StreamLineReader&) = delete;
  StreamLineReader& operator=(const StreamLineReader&) = delete;

  /// The good lines arrived since the last call, in arrival order.
  void take(std::vector<StreamRow>& out);
  /// A bad line of a kind not seen before, once each: (kind, the line).
  std::optional<std::pair<StreamLineError, std::string>> take_new_error();
  Stats stats() const;
  void stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace moa::io
