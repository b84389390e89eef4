#include "moa/sources/stream_lines.hpp"

#include <fcntl.h>
#include <fmt/core.h>
#include <poll.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <mutex>
#include <thread>

#include "moa/formats/csv.hpp"
#include "moa/formats/error.hpp"

namespace moa::io {

const char* describe(StreamLineError e) {
  switch (e) {
    case StreamLineError::kUnknownStream:
      return "unknown stream (not wheels or camera)";
    case StreamLineError::kFieldCount:
      return "wrong number of fields (wheels,t,vx,vy,omega or camera,t,x,y[,theta[,sx,sy]])";
    case StreamLineError::kNotANumber:
      return "a field is not a finite number (sx, sy: positive)";
    case StreamLineError::kTimeBackwards:
      return "t earlier than the stream's previous line's";
    case StreamLineError::kTooLong:
      return "line too long";
  }
  return "?";
}

namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r'))
    s.remove_suffix(1);
  return s;
}

std::optional<double> number(std::string_view s) {
  double x = 0.0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), x);
  if (ec != std::errc() || end != s.data() + s.size() || !std::isfinite(x)) return std::nullopt;
  return x;
}

}  // namespace

std::variant<std::monostate, StreamRow, StreamLineError> parse_stream_line(std::string_view line) {
  if (line.size() > kMaxStreamLine) return StreamLineError::kTooLong;
  line = trim(line);
  if (line.empty() || line.front() == '#') return std::monostate{};
  std::vector<std::string_view> f;
  for (std::size_t from = 0;;) {
    const std::size_t comma = line.find(',', from);
    f.push_back(trim(line.substr(from, comma == std::string_view::npos ? comma : comma - from)));
    if (comma == std::string_view::npos) break;
    from = comma + 1;
  }
  StreamRow out;
  out.stamped = f.size() >= 2 && !f[1].empty();
  const auto numbers = [&](std::size_t first, std::size_t count, double* into) {
    for (std::size_t k = 0; k < count; ++k) {
      const auto x = number(f[first + k]);
      if (!x) return false;
      into[k] = *x;
    }
    return true;
  };
  double t = 0.0;
  if (out.stamped && !numbers(1, 1, &t)) return StreamLineError::kNotANumber;
  if (f[0] == "wheels") {
    if (f.size() != 5) return StreamLineError::kFieldCount;
    double v[3];
    if (!numbers(2, 3, v)) return StreamLineError::kNotANumber;
    out.row = WheelRow{t, Twist2{{v[0], v[1]}, v[2]}};
    return out;
  }
  if (f[0] == "camera") {
    if (f.size() != 4 && f.size() != 5 && f.size() != 7) return StreamLineError::kFieldCount;
    double p[2];
    if (!numbers(2, 2, p)) return StreamLineError::kNotANumber;
    CameraFix fix;
    fix.t = t;
    fix.position = {p[0], p[1]};
    if (f.size() >= 5 && !f[4].empty()) {
      double theta = 0.0;
      if (!numbers(4, 1, &theta)) return StreamLineError::kNotANumber;
      fix.theta = theta;
    }
    if (f.size() == 7) {
      double s[2];
      if (!numbers(5, 2, s) || !(s[0] > 0.0 && s[1] > 0.0)) return StreamLineError::kNotANumber;
      fix.sigma = Vec2{s[0], s[1]};
    }
    out.row = fix;
    return out;
  }
  return StreamLineError::kUnknownStream;
}

std::size_t StreamLineReader::Stats::bad_total() const {
  std::size_t n = 0;
  for (const std::size_t b : bad) n += b;
  return n;
}

struct StreamLineReader::Impl {
  std::string path;
  std::atomic<int> fd{-1};
  bool close_fd = false;
  std::atomic<bool> stopping{false};
  mutable std::mutex mutex;
  std::vector<StreamRow> queue;  ///< under mutex
  Stats stats;                   ///< under mutex
  std::array<bool, kStreamLineErrors> reported{};
  std::thread thread;

  void line(std::string_view text, std::array<std::optional<double>, 2>& last_t) {
    auto parsed = parse_stream_line(text);
    const auto now = std::chrono::steady_clock::now();
    if (std::holds_alternative<std::monostate>(parsed)) return;
    std::lock_guard lock(mutex);
    if (auto* row = std::get_if<StreamRow>(&parsed)) {
      const std::size_t stream = row->row.index();
      const double t = std::visit([](const auto& r) { return static_cast<double>(r.t); }, row->row);
      if (row->stamped) {
        if (last_t[stream] && t < *last_t[stream]) {
          parsed = StreamLineError::kTimeBackwards;
        } else {
          last_t[stream] = t;
        }
      }
      if (auto* good = std::get_if<StreamRow>(&parsed)) {
        good->arrival = now;
        ++(stream == 0 ? stats.wheels : stats.fixes);
        queue.push_back(std::move(*good));
        return;
      }
    }
    const auto e = static_cast<std::size_t>(std::get<StreamLineError>(parsed));
    // Shown to a person: at most 200 bytes, control characters escaped.
    if (stats.bad[e]++ == 0) stats.first[e] = printable(text.substr(0, 200));
  }

  void run() {
    if (fd < 0) {
      // A FIFO: open() waits for its writer, so it is opened here.
      const int opened = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
      if (opened < 0) return;
      close_fd = true;
      fd = opened;
    }
    std::array<std::optional<double>, 2> last_t;
    std::string pending;
    char buffer[4096];
    while (!stopping) {
      pollfd p{fd.load(), POLLIN, 0};
      const int ready = ::poll(&p, 1, 100);
      if (ready < 0 && errno != EINTR) return;
      if (ready <= 0) continue;
      const ssize_t n = ::read(fd.load(), buffer, sizeof buffer);
      if (n < 0 && (errno == EINTR || errno == EAGAIN)) continue;
      if (n <= 0) break;  // end of file: the writer is gone
      for (ssize_t k = 0; k < n; ++k) {
        const char c = buffer[k];
        if (c == '\n') {
          line(pending, last_t);
          pending.clear();
        } else if (pending.size() <= kMaxStreamLine) {
          // One byte past the bound is kept: the line is then too long.
          pending.push_back(c);
        }
      }
    }
    if (!pending.empty() && !stopping) line(pending, last_t);
  }
};

StreamLineReader::StreamLineReader(const std::string& path) : impl_(std::make_unique<Impl>()) {
  impl_->path = path;
  if (path == "-") {
    impl_->fd = STDIN_FILENO;
  } else if (::access(path.c_str(), R_OK) != 0) {
    throw IoError(fmt::format("{}: cannot read ({})", path, std::strerror(errno)));
  }
  impl_->thread = std::thread([impl = impl_.get()] { impl->run(); });
}

StreamLineReader::~StreamLineReader() {
  stop();
  if (impl_->close_fd) ::close(impl_->fd.load());
}

void StreamLineReader::stop() {
  impl_->stopping = true;
  if (impl_->thread.joinable()) {
    // A FIFO without a writer blocks in open(): a writer that opens and
    // closes at once releases it.
    if (impl_->fd < 0) {
      const int w = ::open(impl_->path.c_str(), O_WRONLY | O_NONBLOCK | O_CLOEXEC);
      if (w >= 0) ::close(w);
    }
    impl_->thread.join();
  }
}

void StreamLineReader::take(std::vector<StreamRow>& out) {
  std::lock_guard lock(impl_->mutex);
  out.insert(out.end(), impl_->queue.begin(), impl_->queue.end());
  impl_->queue.clear();
}

std::optional<std::pair<StreamLineError, std::string>> StreamLineReader::take_new_error() {
  std::lock_guard lock(impl_->mutex);
  for (std::size_t e = 0; e < kStreamLineErrors; ++e) {
    if (impl_->stats.bad[e] != 0 && !impl_->reported[e]) {
      impl_->reported[e] = true;
      return std::pair{static_cast<StreamLineError>(e), impl_->stats.first[e]};
    }
  }
  return std::nullopt;
}

StreamLineReader::Stats StreamLineReader::stats() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->stats;
}

}  // namespace moa::io
