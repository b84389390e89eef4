#include "moa/sources/stream_lines.hpp"

#include <fcntl.h>
#include <fmt/core.h>
#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <mutex>
#include <thread>

#include "moa/core/plausible.hpp"
#include "moa/formats/csv.hpp"
#include "moa/formats/error.hpp"
#include "moa/sources/udp.hpp"

namespace moa::io {

const char* describe(StreamLineError e) {
  switch (e) {
    case StreamLineError::kUnknownStream:
      return "unknown stream (not wheels, imu or camera)";
    case StreamLineError::kFieldCount:
      return "wrong number of fields (wheels,t,vx,vy,omega or imu,t,gz or "
             "camera,t,x,y[,theta[,sx,sy]])";
    case StreamLineError::kNotANumber:
      return "a field is not a finite number (sx, sy: positive)";
    case StreamLineError::kTimeBackwards:
      return "t earlier than the stream's previous line's";
    case StreamLineError::kTooLong:
      return "line too long";
    case StreamLineError::kBadJson:
      return "not a flat JSON object of the stream's keys (stream, t and its columns)";
    case StreamLineError::kTimeOutOfRange:
      return "t outside -4e9..4e9 s (the bound of every log's times)";
    case StreamLineError::kImplausible:
      return "a value beyond the plausible (|vx|, |vy| <= 100 m/s; |omega|, |gz| <= 1000 rad/s; "
             "|x|, |y|, sx, sy <= 1e6 m; |theta| <= 1e7 rad)";
    case StreamLineError::kTimeAhead:
      return "t more than 60 s ahead of the source's clock when the line arrived (never taken "
             "as the stream's time)";
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

std::string_view skip_space(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  return s;
}

// A JSON string without escapes at the front of `s` (its text, `s` moved
// past it), nullopt if there is none.
std::optional<std::string_view> json_string_at(std::string_view& s) {
  if (s.empty() || s.front() != '"') return std::nullopt;
  const std::size_t end = s.find_first_of("\"\\", 1);
  if (end == std::string_view::npos || s[end] != '"') return std::nullopt;
  const std::string_view text = s.substr(1, end - 1);
  s.remove_prefix(end + 1);
  return text;
}

// The keys of each stream after "stream", in the order of its CSV columns.
constexpr std::array<std::string_view, 7> kWheelKeys{"t", "vx", "vy", "omega"};
constexpr std::array<std::string_view, 7> kImuKeys{"t", "gz"};
constexpr std::array<std::string_view, 7> kCameraKeys{"t", "x", "y", "theta", "sx", "sy"};

// A flat JSON object as the fields of its CSV line: the stream, then each
// column's number text (empty for a key absent or null), the camera's
// optional columns only as far as given. False for anything else: nesting,
// escapes, a key given twice, a key the stream does not have.
bool json_fields(std::string_view line, std::vector<std::string_view>& f) {
  std::vector<std::pair<std::string_view, std::string_view>> members;
  std::string_view s = skip_space(line.substr(1));
  std::optional<std::string_view> stream;
  if (!s.empty() && s.front() == '}') return false;
  for (;;) {
    const auto key = json_string_at(s);
    if (!key) return false;
    s = skip_space(s);
    if (s.empty() || s.front() != ':') return false;
    s = skip_space(s.substr(1));
    std::string_view value;
    if (const auto text = json_string_at(s)) {
      if (*key != "stream" || stream) return false;
      stream = *text;
    } else {
      const std::size_t end = s.find_first_of(",} \t");
      if (end == std::string_view::npos || end == 0) return false;
      value = s.substr(0, end);
      s.remove_prefix(end);
      if (*key == "stream") return false;
      if (value == "null") value = {};
      for (const auto& m : members) {
        if (m.first == *key) return false;
      }
      members.emplace_back(*key, value);
    }
    s = skip_space(s);
    if (s.empty()) return false;
    if (s.front() == '}') {
      if (!skip_space(s.substr(1)).empty()) return false;
      break;
    }
    if (s.front() != ',') return false;
    s = skip_space(s.substr(1));
  }
  if (!stream) return false;
  f.assign({*stream});
  if (*stream != "wheels" && *stream != "imu" && *stream != "camera") return true;
  const auto& keys = *stream == "wheels" ? kWheelKeys : *stream == "imu" ? kImuKeys : kCameraKeys;
  std::size_t used = 0;
  for (const std::string_view key : keys) {
    if (key.empty()) break;
    std::string_view value;
    for (const auto& m : members) {
      if (m.first == key) {
        value = m.second;
        ++used;
      }
    }
    f.push_back(value);
  }
  if (used != members.size()) return false;
  // A camera line ends after its last column given (theta, or sx and sy;
  // one of sx and sy alone stays, to be refused as a missing number).
  if (*stream == "camera") {
    if (f[5].empty() && f[6].empty()) f.resize(f[4].empty() ? 4 : 5);
  }
  return true;
}

}  // namespace

std::variant<std::monostate, StreamRow, StreamLineError> parse_stream_line(std::string_view line) {
  if (line.size() > kMaxStreamLine) return StreamLineError::kTooLong;
  line = trim(line);
  if (line.empty() || line.front() == '#') return std::monostate{};
  std::vector<std::string_view> f;
  if (line.front() == '{') {
    if (!json_fields(line, f)) return StreamLineError::kBadJson;
  } else {
    for (std::size_t from = 0;;) {
      const std::size_t comma = line.find(',', from);
      f.push_back(trim(line.substr(from, comma == std::string_view::npos ? comma : comma - from)));
      if (comma == std::string_view::npos) break;
      from = comma + 1;
    }
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
  if (!(std::abs(t) <= kMaxTime)) return StreamLineError::kTimeOutOfRange;
  if (f[0] == "wheels") {
    if (f.size() != 5) return StreamLineError::kFieldCount;
    double v[3];
    if (!numbers(2, 3, v)) return StreamLineError::kNotANumber;
    if (!within_plausible(v[0], kMaxPlausibleSpeed) ||
        !within_plausible(v[1], kMaxPlausibleSpeed) || !within_plausible(v[2], kMaxPlausibleRate)) {
      return StreamLineError::kImplausible;
    }
    out.row = WheelRow{t, Twist2{{v[0], v[1]}, v[2]}};
    return out;
  }
  if (f[0] == "imu") {
    if (f.size() != 3) return StreamLineError::kFieldCount;
    double gz = 0.0;
    if (!numbers(2, 1, &gz)) return StreamLineError::kNotANumber;
    if (!within_plausible(gz, kMaxPlausibleRate)) return StreamLineError::kImplausible;
    out.row = ImuRow{t, gz};
    return out;
  }
  if (f[0] == "camera") {
    if (f.size() != 4 && f.size() != 5 && f.size() != 7) return StreamLineError::kFieldCount;
    double p[2];
    if (!numbers(2, 2, p)) return StreamLineError::kNotANumber;
    if (!within_plausible(p[0], kMaxPlausiblePosition) ||
        !within_plausible(p[1], kMaxPlausiblePosition)) {
      return StreamLineError::kImplausible;
    }
    CameraFix fix;
    fix.t = t;
    fix.position = {p[0], p[1]};
    if (f.size() >= 5 && !f[4].empty()) {
      double theta = 0.0;
      if (!numbers(4, 1, &theta)) return StreamLineError::kNotANumber;
      if (!within_plausible(theta, kMaxPlausibleHeading)) return StreamLineError::kImplausible;
      fix.theta = theta;
    }
    if (f.size() == 7) {
      double s[2];
      if (!numbers(5, 2, s) || !(s[0] > 0.0 && s[1] > 0.0)) return StreamLineError::kNotANumber;
      if (s[0] > kMaxPlausiblePosition || s[1] > kMaxPlausiblePosition) {
        return StreamLineError::kImplausible;
      }
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
  StreamClock clock = StreamClock::kSource;
  std::atomic<int> fd{-1};
  bool close_fd = false;
  bool udp = false;  ///< fd is a bound datagram socket
  std::atomic<bool> stopping{false};
  mutable std::mutex mutex;
  std::vector<StreamRow> queue;  ///< under mutex
  Stats stats;                   ///< under mutex
  std::array<bool, kStreamLineErrors> reported{};
  std::optional<SourceClock> source;  ///< under mutex
  bool regular_file = false;          ///< a file waits for the run instead of dropping lines
  std::thread thread;

  // s by which a stamped row's t is ahead of the source's clock now (0 when
  // that clock is not known yet). Under mutex.
  double lead(double t, std::chrono::steady_clock::time_point now) const {
    if (!source) return 0.0;
    const double wall = std::chrono::duration<double>(now - source->arrival).count();
    if (clock == StreamClock::kMonotonic) {
      // t maps as an arrival: source->t + speed (t - arrival), against now's.
      const double now_s = std::chrono::duration<double>(now.time_since_epoch()).count();
      return source->speed * (t - now_s);
    }
    return t - (source->t + source->speed * wall);
  }

  void line(std::string_view text, std::array<std::optional<double>, 3>& last_t) {
    auto parsed = parse_stream_line(text);
    const auto now = std::chrono::steady_clock::now();
    if (std::holds_alternative<std::monostate>(parsed)) return;
    std::lock_guard lock(mutex);
    if (auto* row = std::get_if<StreamRow>(&parsed)) {
      const std::size_t stream = row->row.index();
      const double t = std::visit([](const auto& r) { return static_cast<double>(r.t); }, row->row);
      if (row->stamped) {
        if (lead(t, now) > kMaxStreamLead) {
          parsed = StreamLineError::kTimeAhead;
        } else if (last_t[stream] && t < *last_t[stream]) {
          parsed = StreamLineError::kTimeBackwards;
        } else {
          last_t[stream] = t;
        }
      }
      if (auto* good = std::get_if<StreamRow>(&parsed)) {
        good->arrival = now;
        if (good->stamped && clock == StreamClock::kMonotonic) {
          // Its own time on this machine's monotonic clock, mapped as an arrival.
          good->arrival = std::chrono::steady_clock::time_point(
              std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                  std::chrono::duration<double>(t)));
          good->stamped = false;
        }
        ++(stream == 0 ? stats.wheels : stream == 1 ? stats.fixes : stats.imu);
        if (queue.size() >= kMaxQueuedLines) {
          ++stats.overflow;
          return;
        }
        queue.push_back(std::move(*good));
        return;
      }
    }
    const auto e = static_cast<std::size_t>(std::get<StreamLineError>(parsed));
    // Shown to a person: at most 200 bytes, control characters escaped.
    if (stats.bad[e]++ == 0) stats.first[e] = printable(text.substr(0, 200));
  }

  // Room for the good lines of a whole read: a 64 KiB read holds fewer than
  // kMaxQueuedLines / 2 of them (the shortest, "imu,,0", is 7 bytes).
  bool room() const {
    std::lock_guard lock(mutex);
    return queue.size() <= kMaxQueuedLines / 2;
  }

  void run() {
    if (fd < 0) {
      // A FIFO: open() waits for its writer, so it is opened here.
      const int opened = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
      if (opened < 0) return;
      close_fd = true;
      fd = opened;
    }
    struct stat st {};
    regular_file = ::fstat(fd.load(), &st) == 0 && S_ISREG(st.st_mode);
    std::array<std::optional<double>, 3> last_t;
    std::string pending;
    std::size_t unended = 0;  // bytes since the last line end
    char buffer[65536];       // a datagram whole
    while (!stopping) {
      if (regular_file && !room()) {
        // A file is read as the run takes its lines: none is dropped.
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        continue;
      }
      pollfd p{fd.load(), POLLIN, 0};
      const int ready = ::poll(&p, 1, 100);
      if (ready < 0 && errno != EINTR) return;
      if (ready <= 0) continue;
      const ssize_t n = ::read(fd.load(), buffer, sizeof buffer);
      if (n < 0 && (errno == EINTR || errno == EAGAIN)) continue;
      if (n < 0 && udp) continue;  // an ICMP error of an earlier datagram
      if (n <= 0 && !udp) break;   // end of file: the writer is gone
      for (ssize_t k = 0; k < n; ++k) {
        const char c = buffer[k];
        if (c == '\n') {
          if (unended <= kMaxStreamLine) line(pending, last_t);
          pending.clear();
          unended = 0;
        } else if (++unended <= kMaxStreamLine + 1) {
          // One byte past the bound is kept: the line is then too long,
          // counted at once (a line may never end).
          pending.push_back(c);
          if (unended == kMaxStreamLine + 1) line(pending, last_t);
        }
      }
      if (!udp && unended > kMaxStreamUnended) {
        // No line end in a megabyte (/dev/zero, a binary file): not a
        // stream of lines. Read no further rather than spin on it.
        std::lock_guard lock(mutex);
        stats.not_lines = true;
        break;
      }
      if (udp && !pending.empty()) {
        // A datagram's end ends its last line.
        if (unended <= kMaxStreamLine) line(pending, last_t);
        pending.clear();
        unended = 0;
      }
    }
    if (!pending.empty() && unended <= kMaxStreamLine && !stopping) line(pending, last_t);
  }
};

StreamLineReader::StreamLineReader(const std::string& path, StreamClock clock,
                                   std::optional<SourceClock> source)
    : impl_(std::make_unique<Impl>()) {
  impl_->path = path;
  impl_->clock = clock;
  impl_->source = source;
  if (const auto address = parse_udp_address(path, "--streams")) {
    impl_->fd = open_udp_socket(*address, /*bind=*/true, "--streams");
    impl_->udp = true;
    impl_->close_fd = true;
  } else if (path == "-") {
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

void StreamLineReader::set_source_clock(const SourceClock& clock) {
  std::lock_guard lock(impl_->mutex);
  impl_->source = clock;
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
