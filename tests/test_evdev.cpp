// Linux evdev input (io/evdev.hpp): the decoder of raw struct input_event
// bytes, and the reader's poll loop over several devices, fed through FIFOs
// (no real mouse needed): merge in time, device loss and return, stop.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <linux/input.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "moa/formats/error.hpp"
#include "moa/sources/evdev.hpp"
#include "support/error_of.hpp"
#include "support/synth.hpp"

namespace moa::io {
namespace {

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;

using test::error_of;

// Raw bytes of events, built with the kernel's own struct.
struct Events {
  Bytes bytes;
  Events& add(std::int64_t time_us, std::uint16_t type, std::uint16_t code, std::int32_t value) {
    input_event ev{};
    ev.input_event_sec = static_cast<decltype(ev.input_event_sec)>(time_us / 1000000);
    ev.input_event_usec = static_cast<decltype(ev.input_event_usec)>(time_us % 1000000);
    ev.type = type;
    ev.code = code;
    ev.value = value;
    const auto* p = reinterpret_cast<const std::uint8_t*>(&ev);
    bytes.insert(bytes.end(), p, p + sizeof ev);
    return *this;
  }
  Events& rel(std::int64_t t, std::int32_t dx, std::int32_t dy) {
    if (dx != 0) add(t, EV_REL, REL_X, dx);
    if (dy != 0) add(t, EV_REL, REL_Y, dy);
    return add(t, EV_SYN, SYN_REPORT, 0);
  }
};

// ---------------------------------------------------------------- decoder

TEST(EvdevDecoder, RecordSizeIsTheKernelStruct) {
  EXPECT_EQ(EvdevDecoder::event_size(), sizeof(input_event));
}

TEST(EvdevDecoder, SumsRelativeMotionPerSynReport) {
  Events e;
  e.add(1'000'000, EV_REL, REL_X, 3)
      .add(1'000'000, EV_REL, REL_Y, -2)
      .add(1'000'000, EV_REL, REL_X, 4)  // two REL_X in one frame add up
      .add(1'000'000, EV_REL, REL_WHEEL, 1)
      .add(1'000'007, EV_SYN, SYN_REPORT, 0)
      .add(2'000'000, EV_KEY, BTN_LEFT, 1)
      .add(2'000'000, EV_SYN, SYN_REPORT, 0)  // no motion: no frame
      .add(3'500'000, EV_REL, REL_Y, 9)
      .add(3'500'000, EV_SYN, SYN_REPORT, 0);
  EvdevDecoder decoder;
  std::vector<EvdevFrame> frames;
  decoder.feed(e.bytes, frames);
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].time_us, 1'000'007);
  EXPECT_EQ(frames[0].dx, 7);
  EXPECT_EQ(frames[0].dy, -2);
  EXPECT_EQ(frames[1].time_us, 3'500'000);
  EXPECT_EQ(frames[1].dx, 0);
  EXPECT_EQ(frames[1].dy, 9);
  EXPECT_EQ(decoder.stats().events, 9u);
  EXPECT_EQ(decoder.stats().frames, 2u);
  EXPECT_EQ(decoder.pending_bytes(), 0u);
}

TEST(EvdevDecoder, AnySplitOfTheBytesGivesTheSameFrames) {
  std::mt19937 rng(17);
  std::uniform_int_distribution<int> counts(-40, 40);
  Events e;
  std::int64_t sum_x = 0, sum_y = 0;
  for (int k = 0; k < 500; ++k) {
    const int dx = counts(rng), dy = counts(rng);
    sum_x += dx;
    sum_y += dy;
    e.rel(1'000'000 + 8000 * k, dx, dy);
  }
  EvdevDecoder whole;
  std::vector<EvdevFrame> expected;
  whole.feed(e.bytes, expected);
  std::uniform_int_distribution<std::size_t> piece(0, 3 * sizeof(input_event));
  for (int trial = 0; trial < 20; ++trial) {
    EvdevDecoder decoder;
    std::vector<EvdevFrame> frames;
    std::size_t at = 0;
    while (at < e.bytes.size()) {
      const std::size_t n = std::min(piece(rng), e.bytes.size() - at);
      decoder.feed(std::span<const std::uint8_t>(e.bytes.data() + at, n), frames);
      at += n;
    }
    ASSERT_EQ(frames.size(), expected.size());
    for (std::size_t i = 0; i < frames.size(); ++i) {
      EXPECT_EQ(frames[i].time_us, expected[i].time_us);
      EXPECT_EQ(frames[i].dx, expected[i].dx);
      EXPECT_EQ(frames[i].dy, expected[i].dy);
    }
  }
  std::int64_t got_x = 0, got_y = 0;
  for (const auto& f : expected) {
    got_x += f.dx;
    got_y += f.dy;
  }
  EXPECT_EQ(got_x, sum_x);
  EXPECT_EQ(got_y, sum_y);
}

TEST(EvdevDecoder, HoldsAnIncompleteRecordUntilItIsComplete) {
  Events e;
  e.rel(5, 1, 1);
  EvdevDecoder decoder;
  std::vector<EvdevFrame> frames;
  const std::size_t cut = e.bytes.size() - 3;
  decoder.feed(std::span<const std::uint8_t>(e.bytes.data(), cut), frames);
  EXPECT_TRUE(frames.empty());
  EXPECT_EQ(decoder.pending_bytes(), sizeof(input_event) - 3);
  EXPECT_TRUE(decoder.in_frame());
  decoder.feed(std::span<const std::uint8_t>(e.bytes.data() + cut, 3), frames);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(decoder.pending_bytes(), 0u);
  EXPECT_FALSE(decoder.in_frame());
}

TEST(EvdevDecoder, FarFutureTimesAreClampedNotOverflowed) {
  // sec * 10^6 overflowed int64 (undefined behaviour) for such stamps.
  Bytes bytes;
  for (const auto sec : {std::numeric_limits<decltype(input_event{}.input_event_sec)>::max(),
                         std::numeric_limits<decltype(input_event{}.input_event_sec)>::min()}) {
    input_event ev{};
    ev.input_event_sec = sec;
    ev.input_event_usec = 5;
    ev.type = EV_REL;
    ev.code = REL_X;
    ev.value = 1;
    const auto* p = reinterpret_cast<const std::uint8_t*>(&ev);
    bytes.insert(bytes.end(), p, p + sizeof ev);
    ev.type = EV_SYN;
    ev.code = SYN_REPORT;
    ev.value = 0;
    bytes.insert(bytes.end(), p, p + sizeof ev);
  }
  EvdevDecoder decoder;
  std::vector<EvdevFrame> frames;
  decoder.feed(bytes, frames);
  ASSERT_EQ(frames.size(), 2u);
  constexpr std::int64_t kMaxSec = EvdevDecoder::kMaxEventTimeUs / 1'000'000 - 1;
  EXPECT_EQ(frames[0].time_us, kMaxSec * 1'000'000 + 5);
  EXPECT_EQ(frames[1].time_us, -kMaxSec * 1'000'000 + 5);
}

TEST(EvdevDecoder, SynDroppedIsCountedAndTheMotionAroundItKept) {
  Events e;
  e.add(10, EV_REL, REL_X, 5)
      .add(11, EV_SYN, SYN_DROPPED, 0)
      .add(12, EV_REL, REL_X, 2)
      .add(12, EV_SYN, SYN_REPORT, 0);
  EvdevDecoder decoder;
  std::vector<EvdevFrame> frames;
  decoder.feed(e.bytes, frames);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].dx, 7);
  EXPECT_EQ(decoder.stats().dropped, 1u);
  EXPECT_EQ(decoder.stats().sum_dx, 7);
}

// ----------------------------------------------------------------- reader

class Fifo {
 public:
  explicit Fifo(fs::path path) : path_(std::move(path)) {
    // Made beside and renamed into place, so that a reader looking for the
    // path never finds a FIFO without a writer. Read-write: opening does
    // not block, and the FIFO has a writer from the start, so the reader
    // does not see an end of stream too early.
    const fs::path fresh = path_.string() + ".new";
    if (::mkfifo(fresh.c_str(), 0600) != 0) throw std::runtime_error("mkfifo");
    fd_ = ::open(fresh.c_str(), O_RDWR);
    fs::rename(fresh, path_);
  }
  ~Fifo() { close(); }
  void write(const Bytes& bytes) const {
    ASSERT_EQ(::write(fd_, bytes.data(), bytes.size()), static_cast<ssize_t>(bytes.size()));
  }
  /// The device goes away: the reader sees the end of the stream.
  void close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
  int fd_ = -1;
};

EvdevOptions raw_options(double reopen = 0.0) {
  EvdevOptions options;
  options.accept_raw_streams = true;
  options.reopen_period = reopen;
  options.origin = 1.0;  // device clock: rows are relative to t = 1 s
  return options;
}

TEST(EvdevReader, MergesSeveralDevicesInTimeWithTheirSensorIndices) {
  const auto dir = test::scratch_dir("evdev");
  Fifo a(dir / "a"), b(dir / "b");
  std::vector<std::string> warnings;
  LiveHooks hooks;
  hooks.warn = [&](const std::string& w) { warnings.push_back(w); };
  hooks.tick_period = 0.01;
  EvdevReader reader({{"left", a.path(), 2}, {"right", b.path(), 0}}, raw_options(), hooks);
  EXPECT_EQ(reader.start_time(), 0.0);
  EXPECT_EQ(reader.alive(), 2);

  Events ea, eb;
  std::int64_t sums[3][2] = {};
  for (int k = 0; k < 50; ++k) {
    ea.rel(1'000'000 + 10'000 * k + 3'000, k, -1);
    eb.rel(1'000'000 + 10'000 * k + 7'000, 2, k % 3);
    sums[2][0] += k;
    sums[2][1] -= 1;
    sums[0][0] += 2;
    sums[0][1] += k % 3;
  }
  a.write(ea.bytes);
  b.write(eb.bytes);
  a.close();
  b.close();

  std::vector<SensorRow> rows;
  while (const auto row = reader.next()) rows.push_back(*row);
  ASSERT_EQ(rows.size(), 100u);  // every frame of both moves (a: dy = -1, b: dx = 2)
  std::int64_t got[3][2] = {};
  for (std::size_t i = 0; i < rows.size(); ++i) {
    if (i > 0) {
      EXPECT_GE(rows[i].t, rows[i - 1].t);
    }
    got[rows[i].sensor][0] += static_cast<std::int64_t>(rows[i].counts.x());
    got[rows[i].sensor][1] += static_cast<std::int64_t>(rows[i].counts.y());
  }
  for (const int s : {0, 2}) {
    EXPECT_EQ(got[s][0], sums[s][0]) << s;
    EXPECT_EQ(got[s][1], sums[s][1]) << s;
  }
  // Rows carry device time minus the origin (1 s): the first is a's at 3 ms
  // (its dx = 0 but dy = -1).
  EXPECT_NEAR(rows.front().t, 0.003, 1e-12);
  EXPECT_EQ(rows.front().sensor, 2);
  EXPECT_NEAR(rows.back().t, 0.497, 1e-12);
  EXPECT_EQ(reader.alive(), 0);
  EXPECT_EQ(reader.status(0).lost, 1u);
  ASSERT_EQ(warnings.size(), 2u);
  EXPECT_NE(warnings[0].find("lost (end of stream)"), std::string::npos) << warnings[0];
  fs::remove_all(dir);
}

TEST(EvdevReader, ALostDeviceIsReportedAndTheOthersGoOn) {
  const auto dir = test::scratch_dir("evdev-lost");
  Fifo a(dir / "a"), b(dir / "b");
  std::vector<std::string> warnings;
  std::atomic<int> rows_seen{0};
  LiveHooks hooks;
  hooks.warn = [&](const std::string& w) { warnings.push_back(w); };
  hooks.tick_period = 0.01;
  EvdevReader reader({{"a", a.path(), 0}, {"b", b.path(), 1}}, raw_options(), hooks);

  std::thread device([&] {
    a.write(Events{}.rel(1'100'000, 1, 0).bytes);
    a.close();  // a is unplugged
    while (rows_seen.load() < 1) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    b.write(Events{}.rel(1'200'000, 0, 5).rel(1'300'000, 0, 6).bytes);
    b.close();
  });
  std::vector<SensorRow> rows;
  while (const auto row = reader.next()) {
    rows.push_back(*row);
    ++rows_seen;
  }
  device.join();
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0].sensor, 0);
  EXPECT_EQ(rows[1].sensor, 1);
  EXPECT_EQ(rows[2].counts.y(), 6.0);
  ASSERT_GE(warnings.size(), 1u);
  EXPECT_EQ(warnings[0],
            "mouse a (" + a.path().string() + ") lost (end of stream); 1 of 2 devices left");
  fs::remove_all(dir);
}

TEST(EvdevReader, ALostDeviceIsOpenedAgainWhenItComesBack) {
  const auto dir = test::scratch_dir("evdev-back");
  auto a = std::make_unique<Fifo>(dir / "a");
  std::vector<std::string> warnings;
  std::atomic<int> rows_seen{0};
  std::atomic<bool> back{false};
  LiveHooks hooks;
  hooks.warn = [&](const std::string& w) {
    warnings.push_back(w);
    if (w.find("is back") != std::string::npos) back = true;
  };
  hooks.tick_period = 0.01;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  hooks.stop = [&] { return rows_seen.load() >= 2 || std::chrono::steady_clock::now() > deadline; };
  EvdevReader reader({{"a", dir / "a", 0}}, raw_options(0.02), hooks);

  std::thread device([&] {
    a->write(Events{}.rel(1'100'000, 3, 0).bytes);
    while (rows_seen.load() < 1) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    // Unplugged: the path disappears, then the stream ends.
    fs::remove(dir / "a");
    a->close();
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    // Plugged in again at the same path.
    a = std::make_unique<Fifo>(dir / "a");
    while (!back.load() && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    a->write(Events{}.rel(1'500'000, -4, 0).bytes);
  });
  std::vector<SensorRow> rows;
  while (const auto row = reader.next()) {
    rows.push_back(*row);
    ++rows_seen;
  }
  device.join();
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[1].counts.x(), -4.0);
  EXPECT_NEAR(rows[1].t, 0.5, 1e-12);
  EXPECT_EQ(reader.status(0).lost, 1u);
  EXPECT_TRUE(reader.status(0).alive);
  ASSERT_GE(warnings.size(), 2u);
  EXPECT_NE(warnings[0].find("lost"), std::string::npos);
  EXPECT_EQ(warnings[1], "mouse a (" + (dir / "a").string() + ") is back");
  a.reset();
  fs::remove_all(dir);
}

TEST(EvdevReader, SynDroppedIsReported) {
  const auto dir = test::scratch_dir("evdev-drop");
  Fifo a(dir / "a");
  std::vector<std::string> warnings;
  LiveHooks hooks;
  hooks.warn = [&](const std::string& w) { warnings.push_back(w); };
  EvdevReader reader({{"a", a.path(), 0}}, raw_options(), hooks);
  a.write(Events{}
              .add(1'000'000, EV_REL, REL_X, 1)
              .add(1'000'000, EV_SYN, SYN_DROPPED, 0)
              .add(1'000'100, EV_REL, REL_X, 1)
              .add(1'000'100, EV_SYN, SYN_REPORT, 0)
              .bytes);
  a.close();
  std::vector<SensorRow> rows;
  while (const auto row = reader.next()) rows.push_back(*row);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].counts.x(), 2.0);
  EXPECT_EQ(reader.status(0).dropped, 1u);
  ASSERT_GE(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], "mouse a (" + a.path().string() +
                             "): the kernel dropped events (SYN_DROPPED, 1 so far): their counts "
                             "are lost; resynchronised at the next frame");
  fs::remove_all(dir);
}

TEST(EvdevReader, FrameStampedBeforeOneAlreadyReturnedIsMovedToItsTime) {
  const auto dir = test::scratch_dir("evdev-order");
  Fifo a(dir / "a"), b(dir / "b");
  LiveHooks hooks;
  std::atomic<int> rows_seen{0};
  EvdevReader reader({{"a", a.path(), 0}, {"b", b.path(), 1}}, raw_options(), hooks);
  std::thread device([&] {
    a.write(Events{}.rel(1'200'000, 1, 0).bytes);
    while (rows_seen.load() < 1) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    b.write(Events{}.rel(1'100'000, 0, 1).bytes);  // late, and stamped earlier
    a.close();
    b.close();
  });
  std::vector<SensorRow> rows;
  while (const auto row = reader.next()) {
    rows.push_back(*row);
    ++rows_seen;
  }
  device.join();
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_NEAR(rows[1].t, 0.2, 1e-12);
  EXPECT_EQ(rows[1].counts.y(), 1.0);
  EXPECT_EQ(reader.reordered(), 1u);
  fs::remove_all(dir);
}

TEST(EvdevReader, StopHookEndsAWaitAndTicksAreCalled) {
  const auto dir = test::scratch_dir("evdev-stop");
  Fifo a(dir / "a");
  int ticks = 0;
  LiveHooks hooks;
  hooks.tick_period = 0.01;
  hooks.tick = [&] { ++ticks; };
  hooks.stop = [&] { return ticks >= 3; };
  EvdevReader reader({{"a", a.path(), 0}}, raw_options(1.0), hooks);
  EXPECT_FALSE(reader.next().has_value());
  EXPECT_EQ(ticks, 3);
  fs::remove_all(dir);
}

TEST(EvdevReader, RejectsWhatIsNotAnInputDevice) {
  const auto dir = test::scratch_dir("evdev-bad");
  const auto file = dir / "not-a-device";
  std::ofstream(file) << "x";
  EXPECT_EQ(
      error_of([&] {
        EvdevReader reader({{"m", file, 0}}, EvdevOptions{}, {});
      }),
      file.string() + ": not an input event device (EVIOCGVERSION: " + std::strerror(ENOTTY) + ")");
  const auto missing = dir / "event99";
  EXPECT_EQ(error_of([&] {
              EvdevReader reader({{"m", missing, 0}}, EvdevOptions{}, {});
            }),
            missing.string() + ": cannot open (" + std::strerror(ENOENT) + ")");
  EXPECT_EQ(error_of([] { EvdevReader reader({}, EvdevOptions{}, {}); }),
            "evdev: no devices given");
  fs::remove_all(dir);
}

TEST(EvdevReader, ReadsRecordedBytesFromAFile) {
  const auto dir = test::scratch_dir("evdev-file");
  Events e;
  e.rel(2'000'000, 10, -10).rel(2'010'000, 5, 0);
  const auto file = dir / "capture.bin";
  std::ofstream(file, std::ios::binary)
      .write(reinterpret_cast<const char*>(e.bytes.data()),
             static_cast<std::streamsize>(e.bytes.size()));
  EvdevReader reader({{"m", file, 0}}, raw_options(), {});
  std::vector<SensorRow> rows;
  while (const auto row = reader.next()) rows.push_back(*row);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_NEAR(rows[0].t, 1.0, 1e-12);
  EXPECT_NEAR(rows[1].t, 1.01, 1e-12);
  EXPECT_EQ(rows[0].counts.x() + rows[1].counts.x(), 15.0);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace moa::io
