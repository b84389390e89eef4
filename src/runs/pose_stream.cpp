#include "moa/runs/pose_stream.hpp"

#include <fcntl.h>
#include <fmt/core.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cmath>
#include <csignal>

#include "moa/formats/error.hpp"
#include "moa/sources/udp.hpp"

namespace moa::io {

PoseStream::PoseStream(const std::string& target, const std::vector<std::string>& names,
                       double rate_hz, const std::string& flag)
    : PoseStream(-1, names, rate_hz) {
  if (target == "-") {
    fd_ = STDOUT_FILENO;
  } else if (const auto address = parse_udp_address(target, flag)) {
    fd_ = open_udp_socket(*address, /*bind=*/false, flag);
    udp_ = true;
    return;
  } else {
    throw Error(
        fmt::format("{} {}: expected - (standard output) or udp:[HOST:]PORT", flag, target));
  }
  old_flags_ = ::fcntl(fd_, F_GETFL);
  ::fcntl(fd_, F_SETFL, old_flags_ | O_NONBLOCK);
}

PoseStream::PoseStream(int fd, const std::vector<std::string>& names, double rate_hz)
    : writer_(names), period_(rate_hz > 0 ? 1.0 / rate_hz : 0.0), fd_(fd) {
  // A reader gone is EPIPE, not the end of moa.
  std::signal(SIGPIPE, SIG_IGN);
  if (fd_ >= 0) {
    old_flags_ = ::fcntl(fd_, F_GETFL);
    ::fcntl(fd_, F_SETFL, old_flags_ | O_NONBLOCK);
  }
}

PoseStream::~PoseStream() {
  if (udp_) {
    ::close(fd_);
  } else if (fd_ >= 0 && old_flags_ >= 0) {
    ::fcntl(fd_, F_SETFL, old_flags_);
  }
}

void PoseStream::write(const OdometryStep& step) {
  if (period_ > 0) {
    // The first step at or after each multiple k of the period from the
    // first step's t, to within 1e-6 of a period (epoch times are sums of
    // periods, rounded).
    const double t = step.t();
    if (!started_) {
      first_t_ = t;
      started_ = true;
    }
    const double periods = (t - first_t_) / period_ + 1e-6;
    if (periods < static_cast<double>(next_k_)) return;
    next_k_ = static_cast<std::uint64_t>(std::floor(periods)) + 1;
  }
  const std::string_view line = writer_.format(step, stats_.lines++);
  if (udp_) {
    if (::send(fd_, line.data(), line.size(), MSG_DONTWAIT) != static_cast<ssize_t>(line.size())) {
      ++stats_.dropped;
    }
    return;
  }
  push_out();
  if (gone_ || buffer_.size() - sent_ + line.size() > kBufferBytes) {
    ++stats_.dropped;
    return;
  }
  buffer_.append(line);
  push_out();
}

void PoseStream::push_out() {
  while (!gone_ && sent_ < buffer_.size()) {
    // Whole lines, at most PIPE_BUF bytes (unless one line is longer): a pipe
    // takes such a write whole or not at all, so that its reader never sees
    // part of a line.
    std::size_t size = buffer_.size() - sent_;
    if (size > PIPE_BUF) {
      const std::size_t last = buffer_.rfind('\n', sent_ + PIPE_BUF - 1);
      size = last != std::string::npos && last >= sent_ ? last + 1 - sent_
                                                        : buffer_.find('\n', sent_) + 1 - sent_;
    }
    const ssize_t n = ::write(fd_, buffer_.data() + sent_, size);
    if (n > 0) {
      sent_ += static_cast<std::size_t>(n);
    } else if (n < 0 && errno == EINTR) {
      continue;
    } else if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
      break;
    } else {
      // EPIPE (the reader closed its end) or a write error: nothing more goes out.
      gone_ = true;
      drop_buffered();
    }
  }
  if (sent_ == buffer_.size()) {
    buffer_.clear();
    sent_ = 0;
  } else if (sent_ > kBufferBytes / 2) {
    buffer_.erase(0, sent_);
    sent_ = 0;
  }
}

void PoseStream::drop_buffered() {
  // Each line whose newline was not written is lost (a partly written one too).
  stats_.dropped += static_cast<std::size_t>(
      std::count(buffer_.begin() + static_cast<std::ptrdiff_t>(sent_), buffer_.end(), '\n'));
  buffer_.clear();
  sent_ = 0;
}

void PoseStream::finish(std::chrono::milliseconds wait) {
  if (udp_) return;
  const auto deadline = std::chrono::steady_clock::now() + wait;
  push_out();
  while (!gone_ && !buffer_.empty()) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                          deadline - std::chrono::steady_clock::now())
                          .count();
    if (left <= 0) break;
    pollfd p{fd_, POLLOUT, 0};
    ::poll(&p, 1, static_cast<int>(left));
    push_out();
  }
  drop_buffered();
}

}  // namespace moa::io
