#include "moa/sources/serial_reader.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <deque>
#include <limits>

#include "moa/formats/error.hpp"

namespace moa::io {

std::optional<unsigned> termios_speed(int baud) {
  switch (baud) {
    case 1200:
      return B1200;
    case 2400:
      return B2400;
    case 4800:
      return B4800;
    case 9600:
      return B9600;
    case 19200:
      return B19200;
    case 38400:
      return B38400;
    case 57600:
      return B57600;
    case 115200:
      return B115200;
    case 230400:
      return B230400;
#ifdef B460800
    case 460800:
      return B460800;
#endif
#ifdef B500000
    case 500000:
      return B500000;
#endif
#ifdef B921600
    case 921600:
      return B921600;
#endif
#ifdef B1000000
    case 1000000:
      return B1000000;
#endif
#ifdef B2000000
    case 2000000:
      return B2000000;
#endif
    default:
      return std::nullopt;
  }
}

namespace {

using Clock = std::chrono::steady_clock;

constexpr double kHelloRequestPeriod = 1.0;  // s
// s, how far the device clock may run ahead of its frame count before it is
// taken for a clock step (USB latency does not enter: times are the device's).
constexpr double kMaxClockSlack = 0.5;

Clock::duration seconds(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

void set_up_port(int fd, const std::string& name, int baud) {
  const auto speed = termios_speed(baud);
  if (!speed) throw Error(fmt::format("{}: baud rate {} is not supported", name, baud));
  termios tio{};
  if (::tcgetattr(fd, &tio) < 0) {
    throw Error(fmt::format("{}: not a serial port (tcgetattr: {})", name, std::strerror(errno)));
  }
  // Raw bytes: no line editing, no echo, no CR/LF translation, no XON/XOFF
  // (0x11/0x13 are data here), 8 data bits, no parity, one stop bit, and
  // modem lines ignored so that a three-wire cable works.
  ::cfmakeraw(&tio);
  tio.c_iflag &= ~static_cast<tcflag_t>(IXON | IXOFF | IXANY);
  tio.c_cflag &= ~static_cast<tcflag_t>(CSIZE | PARENB | CSTOPB | CRTSCTS);
  tio.c_cflag |= CS8 | CLOCAL | CREAD;
  // VMIN 1: with O_NONBLOCK an empty queue reads as EAGAIN; with VMIN 0 it
  // would read as 0 bytes, which is how a hang-up reads.
  tio.c_cc[VMIN] = 1;
  tio.c_cc[VTIME] = 0;
  if (::cfsetispeed(&tio, *speed) < 0 || ::cfsetospeed(&tio, *speed) < 0) {
    throw Error(fmt::format("{}: cannot set {} baud ({})", name, baud, std::strerror(errno)));
  }
  if (::tcsetattr(fd, TCSANOW, &tio) < 0) {
    throw Error(fmt::format("{}: cannot set up the port ({})", name, std::strerror(errno)));
  }
  // Nobody else should read our bytes; not every driver supports it.
  ::ioctl(fd, TIOCEXCL);
  ::tcflush(fd, TCIOFLUSH);
}

}  // namespace

struct SerialReader::Impl {
  std::string name;
  int fd = -1;
  std::vector<std::string> config_names;
  std::vector<double> config_cpi;  ///< each config sensor's cpi
  SerialOptions options;
  LiveHooks hooks;

  serial::Decoder decoder;
  serial::DataTracker tracker;
  std::uint64_t lost_before = 0;  // lost frames of trackers replaced after a new tick rate
  serial::Hello hello;
  bool have_hello = false;
  std::vector<int> index;  // device record i -> config sensor
  std::optional<double> base;
  double offset = 0.0;
  double last_t = 0.0;
  std::deque<SensorRow> ready;
  std::vector<GyroSample> gyro;
  // The last DATA frame turned into rows, whose GYRO frame may follow.
  std::optional<std::uint16_t> gyro_sequence;
  // Once the device has shown a gyro, a DATA frame's rows wait here for its
  // GYRO frame (or the next frame), so that a window's sample is taken
  // before its rows are handed out: the order a replay of imu.csv keeps.
  bool gyro_present = false;
  std::vector<SensorRow> held;

  void release_held() {
    ready.insert(ready.end(), held.begin(), held.end());
    held.clear();
  }
  Stats stats;
  bool hung_up = false;
  std::uint64_t bytes = 0;

  Clock::time_point last_data = Clock::time_point::min();
  Clock::time_point last_tick = Clock::now();
  std::optional<Clock::time_point> last_request;
  Stats reported;  // what warnings have told so far

  ~Impl() {
    if (fd >= 0) ::close(fd);
  }

  void write_all(const std::vector<std::uint8_t>& wire, bool must) {
    std::size_t at = 0;
    const auto deadline = Clock::now() + std::chrono::seconds(1);
    while (at < wire.size()) {
      const ssize_t n = ::write(fd, wire.data() + at, wire.size() - at);
      if (n > 0) {
        at += static_cast<std::size_t>(n);
        continue;
      }
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK) && Clock::now() < deadline) {
        pollfd p{fd, POLLOUT, 0};
        ::poll(&p, 1, 50);
        continue;
      }
      if (must) throw Error(fmt::format("{}: cannot write ({})", name, std::strerror(errno)));
      return;
    }
  }

  void on_hello(const serial::Hello& h) {
    std::vector<int> mapped;
    for (const auto& sensor : h.names) {
      const auto it = std::find(config_names.begin(), config_names.end(), sensor);
      if (it == config_names.end()) {
        throw Error(
            fmt::format("{}: the device names sensor '{}', which the robot config does "
                        "not have (config sensors: {})",
                        name, sensor, fmt::join(config_names, ", ")));
      }
      const int sensor_index = static_cast<int>(it - config_names.begin());
      // Two records of one sensor: its counts would be added twice (or one
      // lost) and the others never report; the recording would not replay.
      if (const auto twice = std::find(mapped.begin(), mapped.end(), sensor_index);
          twice != mapped.end()) {
        throw Error(fmt::format(
            "{}: the device's HELLO names sensor '{}' twice (records {} and {} of {}: {}): each "
            "sensor reports once",
            name, sensor, twice - mapped.begin() + 1, mapped.size() + 1, h.names.size(),
            fmt::join(h.names, ",")));
      }
      mapped.push_back(sensor_index);
    }
    // The counts are read at the config's cpi: a device set to another
    // reads its motion that many times off. Said once per HELLO that differs.
    if (h.cpi != 0) {
      std::vector<std::string> differ;
      for (const int i : mapped) {
        const double cpi = config_cpi[static_cast<std::size_t>(i)];
        if (cpi != static_cast<double>(h.cpi)) {
          differ.push_back(fmt::format("'{}' {}", config_names[static_cast<std::size_t>(i)], cpi));
        }
      }
      if (!differ.empty() && (!have_hello || h.cpi != hello.cpi)) {
        hooks.warning(fmt::format(
            "{}: the device's HELLO says {} cpi but the robot config has {}: the config's cpi "
            "reads the counts, so a device at {} cpi reads its motion off by their ratio",
            name, h.cpi, fmt::join(differ, ", "), h.cpi));
      }
    }
    // A HELLO after the first: the device restarted (its sequence and clock
    // start again) or changed its tick rate; times continue from the last row.
    if (have_hello) restart();
    const bool first = !have_hello;
    hello = h;
    have_hello = true;
    index = std::move(mapped);
    if (first && index.size() < config_names.size()) {
      hooks.warning(fmt::format("{}: the device reports {} of the {} sensors of the robot config",
                                name, index.size(), config_names.size()));
    }
  }

  // STATUS: each sensor that is not ok, said once per state it enters.
  std::vector<serial::SensorStatus> sensor_states;
  void on_status(const serial::Status& st) {
    sensor_states.resize(std::max<std::size_t>(sensor_states.size(), st.n));
    for (std::size_t i = 0; i < st.n; ++i) {
      const serial::SensorStatus& now = st.sensors[i];
      serial::SensorStatus& was = sensor_states[i];
      if (now.state == was.state && now.detail == was.detail) continue;
      was = now;
      if (now.state == serial::kSensorOk) continue;
      const std::string who = have_hello && i < hello.names.size()
                                  ? fmt::format("sensor '{}'", hello.names[i])
                                  : fmt::format("sensor {}", i + 1);
      hooks.warning(fmt::format("{}: {} (chip select {}): {}", name, who, i + 1,
                                serial::describe_sensor_state(now)));
    }
  }

  bool rebase_next = false;

  void restart() {
    gyro_sequence.reset();
    lost_before += tracker.lost_frames();
    tracker = serial::DataTracker{};
    rebase_next = true;
    ++stats.restarts;
  }

  // s, the time one DATA frame covers (k samples at frame_rate); one tick
  // when the HELLO does not say.
  double frame_window() const {
    if (hello.frame_rate > 0 && hello.k > 0) {
      return static_cast<double>(hello.k) / hello.frame_rate;
    }
    return 1.0 / static_cast<double>(hello.tick_hz);
  }

  void on_data(const serial::Data& data) {
    release_held();  // the frame before had no GYRO frame
    if (!have_hello) {
      ++stats.before_hello;
      return;
    }
    // A duplicated or late frame would add its counts a second time or out
    // of order: dropped. A sequence behind twice in a row is a restart.
    switch (tracker.classify(data)) {
      case serial::FrameOrder::kRepeat:
        ++stats.duplicates;
        return;
      case serial::FrameOrder::kStale:
        ++stats.stale;
        return;
      case serial::FrameOrder::kRestart:
        restart();
        ++lost_before;  // its first frame, taken for a stale one
        break;
      case serial::FrameOrder::kNext:
        break;
    }
    const std::uint64_t lost_then = tracker.lost_frames();
    const double t_device = tracker.accept(data, hello.tick_hz);
    stats.lost_frames = lost_before + tracker.lost_frames();
    gyro_sequence.reset();
    // It arrived (no sequence gap), but its records cannot be assigned.
    if (data.n != index.size()) {
      ++stats.mismatched;
      return;
    }
    const double window = frame_window();
    // The first row covers one window before it; none when the HELLO gives no rate.
    if (!base) base = t_device - (hello.frame_rate > 0 ? window : 0.0);
    double t = t_device - *base + offset;
    // Frames since the last one (1 + those lost): the device clock should
    // have moved by that many windows. Times stay strictly increasing (two
    // rows of a sensor at one time read as a duplicated line) and never jump
    // by more than kMaxClockSlack beyond that: a restart, a clock stepped
    // back or forwards, continues one window after the last row, so that the
    // recording replays.
    const double frames = static_cast<double>(tracker.lost_frames() - lost_then + 1);
    const bool after_first = stats.data_frames > 0;
    const bool stepped =
        after_first && (t < last_t || t - last_t > frames * window + kMaxClockSlack);
    if (rebase_next || stepped || (after_first && t <= last_t)) {
      if (stepped && !rebase_next) ++stats.clock_steps;
      const double wanted = after_first ? last_t + window : t;
      offset += wanted - t;
      t = wanted;
      rebase_next = false;
    }
    last_t = t;
    last_data = Clock::now();
    gyro_sequence = data.sequence;
    ++stats.data_frames;
    for (std::size_t i = 0; i < data.n; ++i) {
      const auto& s = data.sensors[i];
      SensorRow row;
      row.t = t;
      row.sensor = index[i];
      row.counts = {static_cast<double>(s.dx), static_cast<double>(s.dy)};
      row.squal = s.squal;
      row.flags = s.flags;
      if (s.flags & 1u) ++stats.overflow_rows;
      if (gyro_present) {
        held.push_back(row);
      } else {
        ready.push_back(row);
      }
    }
  }

  // The GYRO frame of the last DATA frame: a sample at that frame's t.
  void on_gyro(const serial::Gyro& g) {
    if (!gyro_sequence || *gyro_sequence != g.sequence) {
      ++stats.gyro_unmatched;
      return;
    }
    gyro_sequence.reset();  // one sample per window
    const bool saturated = (g.flags & serial::kGyroSaturated) != 0;
    gyro.push_back(GyroSample{last_t, g.rate(), saturated});
    gyro_present = true;
    release_held();
    ++stats.gyro_frames;
    if (saturated) ++stats.gyro_saturated;
  }

  void on_bytes(const std::uint8_t* data, std::size_t n) {
    bytes += n;
    for (std::size_t i = 0; i < n; ++i) {
      const auto out = decoder.push(data[i]);
      if (!out) continue;
      if (const auto* message = std::get_if<serial::Message>(&*out)) {
        if (const auto* h = std::get_if<serial::Hello>(message)) {
          release_held();
          on_hello(*h);
        } else if (const auto* d = std::get_if<serial::Data>(message)) {
          on_data(*d);
        } else if (const auto* g = std::get_if<serial::Gyro>(message)) {
          on_gyro(*g);
        } else if (const auto* st = std::get_if<serial::Status>(message)) {
          on_status(*st);
        }
        // Host commands echoed back are not for us.
      }
    }
    stats.corrupt = decoder.stats().corrupt;
    stats.unknown = decoder.stats().unknown;
  }

  // Waits up to one tick for bytes and decodes them.
  void pump() {
    pollfd p{fd, POLLIN, 0};
    const int timeout_ms = std::max(1, static_cast<int>(std::lround(hooks.tick_period * 1000.0)));
    const int n = ::poll(&p, 1, timeout_ms);
    if (n < 0 && errno != EINTR)
      throw Error(fmt::format("{}: poll: {}", name, std::strerror(errno)));
    if (n > 0) {
      std::uint8_t buffer[4096];
      for (;;) {
        const ssize_t got = ::read(fd, buffer, sizeof buffer);
        if (got > 0) {
          on_bytes(buffer, static_cast<std::size_t>(got));
          continue;
        }
        if (got < 0 && errno == EINTR) continue;
        if (got < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
        // 0 from a port that poll() called readable, or EIO: the line is gone.
        hang_up(got == 0 ? "end of stream" : std::strerror(errno));
        break;
      }
      if (!hung_up && (p.revents & (POLLHUP | POLLERR | POLLNVAL))) hang_up("hang-up");
    }
    const auto now = Clock::now();
    if (now - last_tick >= seconds(hooks.tick_period)) {
      last_tick = now;
      report();
      if (hooks.tick) hooks.tick();
    }
  }

  void hang_up(const std::string& why) {
    if (hung_up) return;
    hung_up = true;
    release_held();
    report();
    hooks.warning(fmt::format("{}: device lost ({}); the stream ends", name, why));
  }

  // Warnings for what got worse since the last report, at most once a tick.
  void report() {
    if (stats.corrupt > reported.corrupt) {
      hooks.warning(fmt::format("{}: {} corrupt frames so far (line noise, wrong baud rate?)", name,
                                stats.corrupt));
    }
    if (stats.lost_frames > reported.lost_frames) {
      hooks.warning(
          fmt::format("{}: {} DATA frames lost so far (sequence gaps): their counts are missing",
                      name, stats.lost_frames));
    }
    if (stats.mismatched > reported.mismatched) {
      hooks.warning(fmt::format("{}: {} DATA frames with a sensor count unlike the HELLO's dropped",
                                name, stats.mismatched));
    }
    if (stats.overflow_rows > reported.overflow_rows) {
      hooks.warning(fmt::format("{}: {} rows flagged overflow so far (sensor moved too fast)", name,
                                stats.overflow_rows));
    }
    if (stats.clock_steps > reported.clock_steps) {
      hooks.warning(fmt::format(
          "{}: {} device clock steps so far (back, or ahead of its frames by more than {} s); "
          "times continue from the last row",
          name, stats.clock_steps, kMaxClockSlack));
    }
    if (stats.restarts > reported.restarts) {
      hooks.warning(
          fmt::format("{}: the device restarted ({} so far); times continue from the "
                      "last row",
                      name, stats.restarts));
    }
    if (stats.gyro_unmatched > reported.gyro_unmatched) {
      hooks.warning(fmt::format("{}: {} GYRO frames without their DATA frame dropped so far", name,
                                stats.gyro_unmatched));
    }
    if (stats.gyro_saturated > reported.gyro_saturated) {
      hooks.warning(fmt::format(
          "{}: {} gyro samples saturated so far (turned faster than the gyro's full scale)", name,
          stats.gyro_saturated));
    }
    if (stats.unknown > reported.unknown) {
      hooks.warning(fmt::format(
          "{}: {} frames of a type this moa does not know skipped so far (a newer firmware?)", name,
          stats.unknown));
    }
    if (stats.duplicates > reported.duplicates) {
      hooks.warning(
          fmt::format("{}: {} duplicated DATA frames dropped so far", name, stats.duplicates));
    }
    if (stats.stale > reported.stale) {
      hooks.warning(fmt::format("{}: {} late DATA frames (sequence behind) dropped so far", name,
                                stats.stale));
    }
    reported = stats;
  }

  void start() {
    if (base) return;
    const auto deadline = Clock::now() + seconds(options.start_timeout);
    while (!base) {
      if (hooks.should_stop()) {
        throw Error(fmt::format("{}: stopped before the device started streaming", name));
      }
      if (hung_up) {
        throw Error(fmt::format("{}: device lost before it started streaming", name));
      }
      const auto now = Clock::now();
      if (now >= deadline) {
        throw Error(fmt::format(
            "{}: no {} from the device within {} s ({} bytes, {} corrupt frames received; wrong "
            "port or baud rate?)",
            name, have_hello ? "DATA" : "HELLO", options.start_timeout, bytes,
            decoder.stats().corrupt));
      }
      if (!have_hello && (!last_request || now - *last_request >= seconds(kHelloRequestPeriod))) {
        last_request = now;
        write_all(serial::encode(serial::HelloRequest{}), false);
      }
      pump();
    }
  }
};

SerialReader::SerialReader(const std::filesystem::path& device, const RobotConfig& config,
                           const SerialOptions& options, LiveHooks hooks)
    : impl_(std::make_unique<Impl>()) {
  Impl& impl = *impl_;
  impl.name = device.string();
  impl.config_names = config.names;
  for (int i = 0; i < config.array.size(); ++i) {
    impl.config_cpi.push_back(static_cast<double>(config.array[i].cpi));
  }
  impl.options = options;
  impl.hooks = std::move(hooks);
  const int access = options.configure_port ? O_RDWR : O_RDONLY;
  impl.fd = ::open(device.c_str(), access | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (impl.fd < 0) {
    const int error = errno;
    throw IoError(fmt::format("{}: cannot open ({}){}", impl.name, std::strerror(error),
                              error == EACCES ? "; see docs/hardware.md (group 'dialout')" : ""));
  }
  if (options.configure_port) set_up_port(impl.fd, impl.name, options.baud);
}

SerialReader::~SerialReader() = default;

double SerialReader::start_time() {
  impl_->start();
  return 0.0;
}

std::optional<SensorRow> SerialReader::next() {
  Impl& impl = *impl_;
  impl.start();
  for (;;) {
    if (!impl.ready.empty()) {
      const SensorRow row = impl.ready.front();
      impl.ready.pop_front();
      return row;
    }
    if (impl.hung_up) return std::nullopt;
    if (impl.hooks.should_stop()) {
      if (!impl.held.empty()) {
        impl.release_held();  // the last frame's rows, its GYRO frame not come
        continue;
      }
      impl.report();
      return std::nullopt;
    }
    impl.pump();
  }
}

std::vector<GyroSample> SerialReader::take_gyro() {
  std::vector<GyroSample> out;
  out.swap(impl_->gyro);
  return out;
}

void SerialReader::send(const serial::Message& message) {
  impl_->write_all(serial::encode(message), true);
}

const serial::Hello& SerialReader::hello() const { return impl_->hello; }

const SerialReader::Stats& SerialReader::stats() const { return impl_->stats; }

double SerialReader::seconds_since_data() const {
  if (impl_->last_data == Clock::time_point::min()) return std::numeric_limits<double>::infinity();
  return std::chrono::duration<double>(Clock::now() - impl_->last_data).count();
}

}  // namespace moa::io
