#include "moa/sources/evdev.hpp"

#include <fcntl.h>
#include <linux/input.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <ctime>
#include <deque>
#include <utility>

#include "moa/formats/error.hpp"

namespace moa::io {

// ------------------------------------------------------------- EvdevDecoder

static_assert(sizeof(input_event) <= sizeof(std::uint8_t[64]), "partial buffer too small");

std::size_t EvdevDecoder::event_size() { return sizeof(input_event); }

std::int64_t EvdevDecoder::event_time_us(std::int64_t sec, std::int64_t usec) {
  // A kernel stamps events with a clock of this century; a stream from
  // elsewhere (a file, a pipe) can hold anything. Clamped first, so that
  // neither this sum nor a later difference of two times can overflow.
  constexpr std::int64_t kMaxSec = kMaxEventTimeUs / 1'000'000 - 1;
  sec = std::clamp<std::int64_t>(sec, -kMaxSec, kMaxSec);
  usec = std::clamp<std::int64_t>(usec, -999'999, 999'999);
  return sec * 1'000'000 + usec;
}

void EvdevDecoder::feed(std::span<const std::uint8_t> bytes, std::vector<EvdevFrame>& out) {
  constexpr std::size_t kSize = sizeof(input_event);
  const auto decode = [&](const std::uint8_t* record) {
    input_event ev;
    std::memcpy(&ev, record, kSize);
    event(event_time_us(ev.input_event_sec, ev.input_event_usec), ev.type, ev.code, ev.value, out);
  };
  std::size_t at = 0;
  if (partial_size_ > 0) {
    const std::size_t take = std::min(kSize - partial_size_, bytes.size());
    std::memcpy(partial_ + partial_size_, bytes.data(), take);
    partial_size_ += take;
    at = take;
    if (partial_size_ < kSize) return;
    decode(partial_);
    partial_size_ = 0;
  }
  for (; at + kSize <= bytes.size(); at += kSize) decode(bytes.data() + at);
  partial_size_ = bytes.size() - at;
  std::memcpy(partial_, bytes.data() + at, partial_size_);
}

void EvdevDecoder::event(std::int64_t time_us, std::uint16_t type, std::uint16_t code,
                         std::int32_t value, std::vector<EvdevFrame>& out) {
  ++stats_.events;
  if (type == EV_REL && (code == REL_X || code == REL_Y)) {
    (code == REL_X ? frame_.dx : frame_.dy) += value;
    (code == REL_X ? stats_.sum_dx : stats_.sum_dy) += value;
    motion_ = motion_ || value != 0;
  } else if (type == EV_SYN && code == SYN_REPORT) {
    if (motion_) {
      frame_.time_us = time_us;
      out.push_back(frame_);
      ++stats_.frames;
    }
    frame_ = EvdevFrame{};
    motion_ = false;
  } else if (type == EV_SYN && code == SYN_DROPPED) {
    // The events lost are gone; what was summed before the drop and what
    // follows it are real motion, so the frame goes on.
    ++stats_.dropped;
  }
}

// -------------------------------------------------------------- EvdevReader

namespace {

std::int64_t monotonic_us() {
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);
  return static_cast<std::int64_t>(now.tv_sec) * 1'000'000 + now.tv_nsec / 1000;
}

bool test_bit(const unsigned long* bits, unsigned bit) {
  constexpr unsigned kBitsPerLong = 8 * sizeof(unsigned long);
  return (bits[bit / kBitsPerLong] >> (bit % kBitsPerLong)) & 1ul;
}

std::string errno_text(int error) { return std::strerror(error); }

class Fd {
 public:
  explicit Fd(int fd) : fd_(fd) {}
  ~Fd() {
    if (fd_ >= 0) ::close(fd_);
  }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  int get() const { return fd_; }
  int release() { return std::exchange(fd_, -1); }

 private:
  int fd_;
};

// Reads and drops whatever is queued (events stamped before the clock switch).
void discard_pending(int fd) {
  std::uint8_t buffer[4096];
  while (::read(fd, buffer, sizeof buffer) > 0) {
  }
}

struct Opened {
  int fd = -1;
  std::string device_name;
};

Opened open_device(const EvdevDevice& spec, const EvdevOptions& options) {
  const std::string path = spec.path.string();
  Fd fd(::open(spec.path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC));
  if (fd.get() < 0) {
    const int error = errno;
    throw IoError(
        fmt::format("{}: cannot open ({}){}", path, errno_text(error),
                    error == EACCES ? "; see docs/hardware.md (group 'input', udev rule)" : ""));
  }
  int version = 0;
  if (::ioctl(fd.get(), EVIOCGVERSION, &version) < 0) {
    const int error = errno;
    if (options.accept_raw_streams) return {fd.release(), ""};
    throw Error(
        fmt::format("{}: not an input event device (EVIOCGVERSION: {})", path, errno_text(error)));
  }
  char name[256] = {};
  if (::ioctl(fd.get(), EVIOCGNAME(sizeof name - 1), name) < 0) name[0] = '\0';
  unsigned long rel_bits[(REL_MAX + 8 * sizeof(unsigned long)) / (8 * sizeof(unsigned long))] = {};
  if (::ioctl(fd.get(), EVIOCGBIT(EV_REL, sizeof rel_bits), rel_bits) < 0 ||
      !test_bit(rel_bits, REL_X) || !test_bit(rel_bits, REL_Y)) {
    throw Error(fmt::format("{}: '{}' reports no relative X/Y motion (not a mouse)", path, name));
  }
  int clock = CLOCK_MONOTONIC;
  if (::ioctl(fd.get(), EVIOCSCLOCKID, &clock) < 0) {
    throw Error(
        fmt::format("{}: cannot switch its timestamps to CLOCK_MONOTONIC (EVIOCSCLOCKID: {})", path,
                    errno_text(errno)));
  }
  if (options.grab && ::ioctl(fd.get(), EVIOCGRAB, 1) < 0) {
    throw Error(fmt::format("{}: cannot grab it (EVIOCGRAB: {}); another program holds it?", path,
                            errno_text(errno)));
  }
  discard_pending(fd.get());
  return {fd.release(), name};
}

}  // namespace

struct EvdevReader::Impl {
  struct Device {
    EvdevDevice spec;
    int fd = -1;
    EvdevDecoder decoder;
    DeviceStatus status;
    std::uint64_t dropped_reported = 0;
    std::chrono::steady_clock::time_point retry_at;
  };

  std::vector<Device> devices;
  EvdevOptions options;
  LiveHooks hooks;
  std::int64_t origin_us = 0;
  std::deque<SensorRow> ready;
  double last_t = 0.0;
  std::uint64_t reordered = 0;
  std::vector<std::pair<EvdevFrame, int>> batch;
  std::vector<EvdevFrame> frames;
  std::vector<pollfd> polls;
  std::vector<std::size_t> polled;  // device index of each pollfd
  std::chrono::steady_clock::time_point last_tick = std::chrono::steady_clock::now();

  ~Impl() {
    for (auto& d : devices) {
      if (d.fd >= 0) ::close(d.fd);
    }
  }

  std::string label(const Device& d) const {
    return fmt::format("{} ({})", d.spec.name, d.spec.path.string());
  }

  int alive() const {
    return static_cast<int>(
        std::count_if(devices.begin(), devices.end(), [](const Device& d) { return d.fd >= 0; }));
  }

  void lose(Device& d, const std::string& why) {
    ::close(d.fd);
    d.fd = -1;
    d.status.alive = false;
    ++d.status.lost;
    // A frame cut off by the loss is incomplete; start clean when it is back.
    d.decoder = EvdevDecoder{};
    d.retry_at = std::chrono::steady_clock::now() +
                 std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                     std::chrono::duration<double>(options.reopen_period));
    const int left = alive();
    hooks.warning(fmt::format("mouse {} lost ({}); {} of {} devices left{}", label(d), why, left,
                              devices.size(),
                              options.reopen_period > 0 ? ", will look for it again" : ""));
  }

  // Reads everything queued; a device that fails is lost.
  void drain(Device& d, std::size_t index) {
    std::uint8_t buffer[4096];
    for (;;) {
      const ssize_t n = ::read(d.fd, buffer, sizeof buffer);
      if (n > 0) {
        frames.clear();
        d.decoder.feed(std::span<const std::uint8_t>(buffer, static_cast<std::size_t>(n)), frames);
        for (const auto& f : frames) batch.emplace_back(f, static_cast<int>(index));
        d.status.frames = d.decoder.stats().frames;
        report_drops(d);
        continue;
      }
      if (n == 0) {
        lose(d, "end of stream");
        return;
      }
      if (errno == EINTR) continue;
      if (errno == EAGAIN || errno == EWOULDBLOCK) return;
      lose(d, errno_text(errno));
      return;
    }
  }

  void report_drops(Device& d) {
    const std::uint64_t dropped = d.decoder.stats().dropped;
    if (dropped == d.dropped_reported) return;
    d.status.dropped += dropped - d.dropped_reported;
    d.dropped_reported = dropped;
    hooks.warning(fmt::format(
        "mouse {}: the kernel dropped events (SYN_DROPPED, {} so far): their counts are lost; "
        "resynchronised at the next frame",
        label(d), d.status.dropped));
  }

  void retry_lost() {
    const auto now = std::chrono::steady_clock::now();
    for (auto& d : devices) {
      if (d.fd >= 0 || options.reopen_period <= 0 || now < d.retry_at) continue;
      try {
        const Opened opened = open_device(d.spec, options);
        d.fd = opened.fd;
        d.status.alive = true;
        d.status.device_name = opened.device_name;
        d.dropped_reported = 0;
        hooks.warning(fmt::format("mouse {} is back", label(d)));
      } catch (const Error&) {
        d.retry_at = now + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                               std::chrono::duration<double>(options.reopen_period));
      }
    }
  }

  void wait_once() {
    polls.clear();
    polled.clear();
    for (std::size_t i = 0; i < devices.size(); ++i) {
      if (devices[i].fd < 0) continue;
      polls.push_back({devices[i].fd, POLLIN, 0});
      polled.push_back(i);
    }
    const int timeout_ms = std::max(1, static_cast<int>(std::lround(hooks.tick_period * 1000.0)));
    const int n = ::poll(polls.data(), polls.size(), timeout_ms);
    if (n < 0 && errno != EINTR) throw Error(fmt::format("evdev: poll: {}", errno_text(errno)));
    batch.clear();
    if (n > 0) {
      // Every live device is read, not only those poll named: frames that
      // arrived meanwhile are merged in this round rather than the next.
      for (std::size_t k = 0; k < polls.size(); ++k) {
        Device& d = devices[polled[k]];
        if (d.fd < 0) continue;
        drain(d, polled[k]);
        if (d.fd >= 0 && (polls[k].revents & (POLLHUP | POLLERR | POLLNVAL))) {
          lose(d, (polls[k].revents & POLLHUP) ? "hang-up" : "device error");
        }
      }
    }
    std::stable_sort(batch.begin(), batch.end(), [](const auto& a, const auto& b) {
      return a.first.time_us < b.first.time_us;
    });
    for (const auto& [frame, index] : batch) {
      SensorRow row;
      row.t = static_cast<double>(frame.time_us - origin_us) / 1e6;
      if (row.t < last_t) {
        row.t = last_t;
        ++reordered;
      }
      last_t = row.t;
      row.sensor = devices[static_cast<std::size_t>(index)].spec.sensor;
      row.counts = {static_cast<double>(frame.dx), static_cast<double>(frame.dy)};
      ready.push_back(row);
    }
    retry_lost();
    const auto now = std::chrono::steady_clock::now();
    if (hooks.tick && now - last_tick >= std::chrono::duration<double>(hooks.tick_period)) {
      last_tick = now;
      hooks.tick();
    }
  }
};

EvdevReader::EvdevReader(const std::vector<EvdevDevice>& devices, const EvdevOptions& options,
                         LiveHooks hooks)
    : impl_(std::make_unique<Impl>()) {
  if (devices.empty()) throw Error("evdev: no devices given");
  impl_->options = options;
  impl_->hooks = std::move(hooks);
  for (const auto& spec : devices) {
    Impl::Device device;
    device.spec = spec;
    impl_->devices.push_back(std::move(device));
    const Opened opened = open_device(spec, options);
    impl_->devices.back().fd = opened.fd;
    impl_->devices.back().status.alive = true;
    impl_->devices.back().status.device_name = opened.device_name;
  }
  constexpr double kMaxOrigin = static_cast<double>(EvdevDecoder::kMaxEventTimeUs) / 1e6;
  if (options.origin && !(std::abs(*options.origin) <= kMaxOrigin)) {
    throw Error(fmt::format("evdev: origin {} s is out of range (at most {:g} s)", *options.origin,
                            kMaxOrigin));
  }
  impl_->origin_us = options.origin ? static_cast<std::int64_t>(std::llround(*options.origin * 1e6))
                                    : monotonic_us();
}

EvdevReader::~EvdevReader() = default;

double EvdevReader::start_time() { return 0.0; }

std::optional<SensorRow> EvdevReader::next() {
  Impl& impl = *impl_;
  for (;;) {
    if (!impl.ready.empty()) {
      const SensorRow row = impl.ready.front();
      impl.ready.pop_front();
      return row;
    }
    if (impl.hooks.should_stop()) return std::nullopt;
    if (impl.alive() == 0 && impl.options.reopen_period <= 0) return std::nullopt;
    impl.wait_once();
  }
}

const EvdevReader::DeviceStatus& EvdevReader::status(int device) const {
  return impl_->devices.at(static_cast<std::size_t>(device)).status;
}

int EvdevReader::alive() const { return impl_->alive(); }

std::uint64_t EvdevReader::reordered() const { return impl_->reordered; }

}  // namespace moa::io
