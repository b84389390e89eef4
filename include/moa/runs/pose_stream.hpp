// The pose stream of `moa live --pose-out` (docs/formats/pose-stream.md):
// one line per step (formats/pose_line.hpp), or per 1/rate seconds of the
// steps' time, sent without ever waiting for the reader.
//
// To standard output (or any descriptor): the descriptor is made
// non-blocking and lines go through a buffer of kBufferBytes; a line that
// does not fit whole is dropped and counted (a reader that is slow or has
// stopped), as is every line after the reader is gone (EPIPE; SIGPIPE is
// ignored from then on). Writes are of whole lines, at most PIPE_BUF bytes
// (4096 on Linux), which a pipe takes whole or not at all: its reader never
// sees part of a line (a line longer than that, 16 long sensor names, may
// be split, and then cut if the run ends before the reader takes the rest).
// To UDP: one datagram per line, sent with MSG_DONTWAIT on a connected
// socket; a send the kernel refuses (no buffer space, no one listening:
// ECONNREFUSED) is a dropped line. A datagram the kernel accepted but the
// reader's full receive buffer then discards is not seen by the sender: the
// line's `seq` lets the reader count those (a gap).
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "moa/core/odometry.hpp"
#include "moa/formats/pose_line.hpp"

namespace moa::io {

class PoseStream {
 public:
  /// Bytes of lines waiting for a descriptor's reader, at most.
  static constexpr std::size_t kBufferBytes = 64 * 1024;

  struct Stats {
    std::size_t lines = 0;    ///< lines made (sequence numbers handed out)
    std::size_t dropped = 0;  ///< of them, not handed to the reader's side
  };

  /// `target`: "-" (standard output) or "udp:[HOST:]PORT". `rate_hz` 0: a
  /// line per step; else a line for the first step at or after each
  /// multiple of 1/rate_hz s from the first step's t. Throws io::Error
  /// naming `flag` for a target it cannot use.
  PoseStream(const std::string& target, const std::vector<std::string>& names, double rate_hz,
             const std::string& flag = "--pose-out");
  /// To descriptor `fd` (not owned, e.g. a pipe's end), as for standard output.
  PoseStream(int fd, const std::vector<std::string>& names, double rate_hz);
  ~PoseStream();
  PoseStream(const PoseStream&) = delete;
  PoseStream& operator=(const PoseStream&) = delete;

  /// The line of `step` (when the rate selects it), sent or dropped at once.
  void write(const OdometryStep& step);
  /// Writes what a descriptor's buffer holds, waiting at most `wait` for the
  /// reader; lines still not written are dropped. Nothing to do for UDP.
  void finish(std::chrono::milliseconds wait);
  Stats stats() const { return stats_; }

 private:
  void push_out();
  void drop_buffered();
  PoseLineWriter writer_;
  double period_ = 0.0;       ///< s, 0: every step
  double first_t_ = 0.0;      ///< s, the first step's time, with period_
  std::uint64_t next_k_ = 0;  ///< the next line's multiple of period_
  bool started_ = false;
  int fd_ = -1;
  bool udp_ = false;
  int old_flags_ = -1;    ///< the descriptor's flags before (restored)
  bool gone_ = false;     ///< the reader closed its end
  std::string buffer_;    ///< whole lines not yet written (descriptor)
  std::size_t sent_ = 0;  ///< bytes of buffer_ already written
  Stats stats_;
};

}  // namespace moa::io
