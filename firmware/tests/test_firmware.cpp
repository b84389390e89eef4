// The acquisition firmware in simavr: simulated ADNS-3080 sensors play a
// motion script, the UART is parsed with moa's host decoder, and every
// DATA frame is checked against the script it covers.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <ostream>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "adns3080_model.hpp"
#include "avr_bench.hpp"
#include "firmware_builds.hpp"
#include "moa/sources/serial_protocol.hpp"

namespace moa::firmware_sim {

// Failure messages show the build's name, not its bytes.
void PrintTo(const FirmwareBuild& build, std::ostream* os) { *os << build.name; }

namespace {

namespace serial = moa::io::serial;

// The firmware's documented SQUAL floor (docs/firmware.md): scripts keep
// normal SQUAL at 30 or more and "lifted" SQUAL at 5, far from it.
constexpr int kSqualFloor = 16;
constexpr std::uint8_t kLowSqual = 5;
constexpr std::uint8_t kIdleSqual = 100;
constexpr std::uint8_t kFlagOverflow = 0x01;
constexpr std::uint8_t kFlagNoSurface = 0x02;
// Start-up: a 50 ms wait after the sensor reset, then the checks.
constexpr double kBootUs = 60000.0;
// From a frame tick to the first byte of sensor 0's burst: interrupt entry
// and the register saves of an interrupt that calls functions, the tick
// bookkeeping, the 1 us chip-select set-up (about 200 cycles together), and
// at most one UART interrupt or interrupts-masked section already running
// (about 100 more). Bound: 400 cycles.
constexpr double kReadLatencyCycles = 400.0;

struct SensorSetup {
  std::vector<MotionFrame> script;
  bool connected = true;
  std::uint8_t product_id = Adns3080Model::kProductId;
};

/// Motion frames with counts in [-90, 90] and SQUAL in [30, 120].
std::vector<MotionFrame> random_script(std::uint32_t seed, std::size_t frames) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> count(-90, 90);
  std::uniform_int_distribution<int> squal(30, 120);
  std::vector<MotionFrame> script(frames);
  for (MotionFrame& f : script) {
    f.dx = static_cast<std::int8_t>(count(rng));
    f.dy = static_cast<std::int8_t>(count(rng));
    f.squal = static_cast<std::uint8_t>(squal(rng));
  }
  return script;
}

/// What the protocol says a record over reads [begin, end) of `script`
/// must hold (docs/serial-protocol.md, DATA).
serial::SensorCounts expected_record(const std::vector<MotionFrame>& script, std::size_t begin,
                                     std::size_t end) {
  long long sx = 0;
  long long sy = 0;
  int min_squal = 255;
  std::uint8_t flags = 0;
  for (std::size_t r = begin; r < end; ++r) {
    const MotionFrame f = r < script.size() ? script[r] : MotionFrame{0, 0, kIdleSqual, false};
    sx += f.dx;
    sy += f.dy;
    min_squal = std::min<int>(min_squal, f.squal);
    if (f.overflow) flags |= kFlagOverflow;
  }
  const auto clamp = [&flags](long long v) {
    constexpr long long lo = std::numeric_limits<std::int16_t>::min();
    constexpr long long hi = std::numeric_limits<std::int16_t>::max();
    if (v < lo || v > hi) flags |= kFlagOverflow;
    return static_cast<std::int16_t>(std::clamp(v, lo, hi));
  };
  serial::SensorCounts c;
  c.dx = clamp(sx);
  c.dy = clamp(sy);
  c.squal = static_cast<std::uint8_t>(min_squal);
  if (min_squal < kSqualFloor) flags |= kFlagNoSurface;
  c.flags = flags;
  return c;
}

/// The firmware in simavr with its UART decoded as it runs.
class Session {
 public:
  /// `gyro`: an MPU-6050 on the TWI bus, or none.
  Session(const FirmwareBuild& build, const std::vector<SensorSetup>& setups,
          std::unique_ptr<Mpu6050Model> gyro = nullptr)
      : build_(build), setups_(setups), bench_(build, make_models(setups)) {
    if (gyro) bench_.attach_gyro(std::move(gyro));
  }

  /// Runs until `done` holds (checked every simulated millisecond);
  /// false if `timeout_us` of simulated time passed first.
  bool run_until(const std::function<bool()>& done, double timeout_us) {
    const double end = bench_.now_us() + timeout_us;
    while (!done()) {
      if (bench_.now_us() >= end) return false;
      bench_.run_until_us(bench_.now_us() + 1000.0);
      drain();
    }
    return true;
  }
  void run_for(double us) {
    bench_.run_until_us(bench_.now_us() + us);
    drain();
  }

  void send(const serial::Message& message) { bench_.send(serial::encode(message)); }
  void send_raw(const std::vector<std::uint8_t>& bytes) { bench_.send(bytes); }

  std::vector<serial::Data> data() const { return of_type<serial::Data>(); }
  std::vector<serial::Hello> hellos() const { return of_type<serial::Hello>(); }
  std::vector<serial::Gyro> gyros() const { return of_type<serial::Gyro>(); }
  const std::vector<serial::Message>& received() const { return received_; }
  const serial::Decoder::Stats& stats() const { return decoder_.stats(); }
  AvrBench& bench() { return bench_; }
  const FirmwareBuild& build() const { return build_; }
  const SensorSetup& setup(std::size_t i) const { return setups_[i]; }

  /// Simulated time of the frame tick a DATA timestamp names: the epoch
  /// is when the firmware started its timer.
  double tick_time_us(std::uint32_t timestamp) {
    return bench_.clock_start_us() + timestamp * 1e6 / (build_.f_cpu / 8.0);
  }
  /// Motion bursts sensor i had served up to and including the read of
  /// the frame tick a DATA timestamp names: those begun before the next
  /// tick (a frame's reads fit in its period, checked separately).
  std::size_t reads_through(std::size_t i, std::uint32_t timestamp) {
    return reads_before(i, tick_time_us(timestamp) + 1e6 / build_.frame_hz);
  }

  /// Motion bursts sensor i had served before time t.
  std::size_t reads_before(std::size_t i, double t_us) {
    const SpiChip* model = bench_.sensor(i);
    if (model == nullptr) return 0;
    const auto& times = model->burst_times();
    return static_cast<std::size_t>(std::lower_bound(times.begin(), times.end(), t_us) -
                                    times.begin());
  }

  /// Every data-sheet or bus rule the firmware broke, all sensors.
  std::vector<std::string> violations() {
    std::vector<std::string> all = bench_.violations();
    for (std::size_t i = 0; i < setups_.size(); ++i) {
      if (const SpiChip* m = bench_.sensor(i)) {
        for (const std::string& v : m->violations())
          all.push_back("sensor " + std::to_string(i) + ": " + v);
      }
    }
    return all;
  }

 private:
  static std::vector<std::unique_ptr<SpiChip>> make_models(const std::vector<SensorSetup>& setups) {
    std::vector<std::unique_ptr<SpiChip>> models;
    for (const SensorSetup& s : setups) {
      models.push_back(s.connected
                           ? std::make_unique<Adns3080Model>(s.script, s.product_id, kIdleSqual)
                           : nullptr);
    }
    return models;
  }

  void drain() {
    const auto& bytes = bench_.uart();
    for (; consumed_ < bytes.size(); ++consumed_) {
      const auto out = decoder_.push(bytes[consumed_].value);
      if (!out) continue;
      if (const auto* m = std::get_if<serial::Message>(&*out)) received_.push_back(*m);
    }
  }

  template <class T>
  std::vector<T> of_type() const {
    std::vector<T> out;
    for (const serial::Message& r : received_) {
      if (const auto* m = std::get_if<T>(&r)) out.push_back(*m);
    }
    return out;
  }

  FirmwareBuild build_;
  std::vector<SensorSetup> setups_;
  AvrBench bench_;
  serial::Decoder decoder_;
  std::vector<serial::Message> received_;
  std::size_t consumed_ = 0;
};

std::vector<SensorSetup> random_sensors(int n, std::size_t frames) {
  std::vector<SensorSetup> setups(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    setups[static_cast<std::size_t>(i)].script =
        random_script(800u + static_cast<std::uint32_t>(i), frames);
  }
  return setups;
}

bool is_absent(const SensorSetup& setup) {
  return !setup.connected || setup.product_id != Adns3080Model::kProductId;
}

/// Frame d of the stream covers, for each sensor, the bursts it served
/// after the read at frame d-1's timestamp, up to the read at frame d's.
/// Checks every record against the script over exactly those reads.
void expect_frames_match_script(Session& s) {
  const auto n = static_cast<std::size_t>(s.build().sensors);
  std::vector<std::size_t> previous(n, 0);
  std::uint16_t sequence = 0;
  for (const serial::Message& r : s.received()) {
    const auto* data = std::get_if<serial::Data>(&r);
    if (data == nullptr) continue;
    // Windows follow each other only if no frame is missing.
    ASSERT_EQ(data->sequence, sequence++);
    ASSERT_EQ(data->n, n);
    for (std::size_t i = 0; i < n; ++i) {
      SCOPED_TRACE("sequence " + std::to_string(data->sequence) + ", sensor " + std::to_string(i));
      const serial::SensorCounts& got = data->sensors[i];
      serial::SensorCounts want{0, 0, 0, kFlagNoSurface};
      if (!is_absent(s.setup(i))) {
        const std::size_t now = s.reads_through(i, data->timestamp);
        want = expected_record(s.setup(i).script, previous[i], now);
        previous[i] = now;
      }
      EXPECT_EQ(got.dx, want.dx);
      EXPECT_EQ(got.dy, want.dy);
      EXPECT_EQ(got.squal, want.squal);
      EXPECT_EQ(got.flags, want.flags);
    }
  }
}

/// Sensor frames (bursts of sensor `i`) between consecutive DATA frames.
std::vector<std::size_t> reads_per_frame(Session& s, std::size_t i) {
  std::vector<std::size_t> out;
  std::size_t previous = 0;
  for (const serial::Message& r : s.received()) {
    const auto* data = std::get_if<serial::Data>(&r);
    if (data == nullptr) continue;
    const std::size_t now = s.reads_through(i, data->timestamp);
    out.push_back(now - previous);
    previous = now;
  }
  return out;
}

void expect_no_violations(Session& s) {
  const std::vector<std::string> violations = s.violations();
  EXPECT_TRUE(violations.empty()) << violations.size() << " violations, first: "
                                  << (violations.empty() ? "" : violations.front());
}

std::size_t index_of_nth_hello(const Session& s, std::size_t nth) {
  std::size_t seen = 0;
  for (std::size_t m = 0; m < s.received().size(); ++m) {
    if (std::holds_alternative<serial::Hello>(s.received()[m]) && seen++ == nth) return m;
  }
  return s.received().size();
}

// ------------------------------------------------- every ADNS-3080 build

/// The ADNS-3080 builds (the PixArt chips' have their own tests,
/// test_firmware_pixart.cpp).
std::vector<FirmwareBuild> adns_builds() {
  std::vector<FirmwareBuild> out;
  for (const FirmwareBuild& b : kFirmwareBuilds) {
    if (b.sensor == "ADNS3080") out.push_back(b);
  }
  return out;
}

class FirmwareBuilds : public ::testing::TestWithParam<FirmwareBuild> {};

TEST_P(FirmwareBuilds, HelloComesFirstAndDescribesTheBuild) {
  const FirmwareBuild& build = GetParam();
  Session s(build, random_sensors(build.sensors, 100));
  ASSERT_TRUE(s.run_until([&] { return !s.data().empty(); }, kBootUs + 50000.0));

  // A lone delimiter flushes the host's receiver, then the HELLO.
  ASSERT_FALSE(s.bench().uart().empty());
  EXPECT_EQ(s.bench().uart().front().value, 0);
  ASSERT_TRUE(std::holds_alternative<serial::Hello>(s.received().front()));
  EXPECT_EQ(s.stats().corrupt, 0u);

  const serial::Hello hello = std::get<serial::Hello>(s.received().front());
  EXPECT_EQ(hello.version, 1);
  EXPECT_EQ(hello.k, build.k);
  EXPECT_EQ(hello.frame_rate, build.frame_hz);
  EXPECT_EQ(hello.cpi, build.cpi);
  EXPECT_EQ(hello.tick_hz, build.f_cpu / 8u);
  ASSERT_EQ(hello.names.size(), static_cast<std::size_t>(build.sensors));
  for (int i = 0; i < build.sensors; ++i) {
    EXPECT_EQ(hello.names[static_cast<std::size_t>(i)], "m" + std::to_string(i + 1));
  }
}

TEST_P(FirmwareBuilds, DataFramesSumTheirWindowOfScriptedMotion) {
  const FirmwareBuild& build = GetParam();
  const auto n = static_cast<std::size_t>(build.sensors);
  std::vector<SensorSetup> setups = random_sensors(build.sensors, 200);
  // Sensor 0 overflows in read 7, sensor 1 loses the surface in read 30,
  // the last sensor overflows the other way in read 40.
  setups[0].script[7] = MotionFrame{127, 127, 60, true};
  if (n > 1) setups[1].script[30].squal = kLowSqual;
  if (n > 2) setups[n - 1].script[40] = MotionFrame{-128, -128, 60, true};
  Session s(build, setups);
  const std::size_t reads_needed = 48;
  const auto frames =
      (reads_needed + static_cast<std::size_t>(build.k) - 1) / static_cast<std::size_t>(build.k);
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= frames; }, kBootUs + 200000.0));

  expect_frames_match_script(s);
  EXPECT_EQ(s.stats().corrupt, 0u);

  // The scripted events fell into the frames the stream holds.
  const std::vector<serial::Data> data = s.data();
  const auto k = static_cast<std::size_t>(build.k);
  EXPECT_EQ(data[7 / k].sensors[0].flags & kFlagOverflow, kFlagOverflow);
  if (n > 1) {
    EXPECT_EQ(data[30 / k].sensors[1].flags & kFlagNoSurface, kFlagNoSurface);
    EXPECT_EQ(data[30 / k].sensors[1].squal, kLowSqual);
  }
  if (n > 2) {
    EXPECT_EQ(data[40 / k].sensors[n - 1].flags & kFlagOverflow, kFlagOverflow);
  }

  // Nothing lost or invented: the totals are the script's totals.
  for (std::size_t i = 0; i < n; ++i) {
    long long sent_x = 0;
    long long sent_y = 0;
    for (const serial::Data& d : data) {
      sent_x += d.sensors[i].dx;
      sent_y += d.sensors[i].dy;
    }
    long long script_x = 0;
    long long script_y = 0;
    for (std::size_t r = 0; r < data.size() * k; ++r) {
      script_x += setups[i].script[r].dx;
      script_y += setups[i].script[r].dy;
    }
    EXPECT_EQ(sent_x, script_x) << "sensor " << i;
    EXPECT_EQ(sent_y, script_y) << "sensor " << i;
  }
}

TEST_P(FirmwareBuilds, DataFramesComeEveryKSensorFramesWithCountingSequence) {
  const FirmwareBuild& build = GetParam();
  Session s(build, random_sensors(build.sensors, 200));
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 8; }, kBootUs + 200000.0));

  const std::vector<serial::Data> data = s.data();
  const std::uint32_t tick_hz = build.f_cpu / 8u;
  const std::uint32_t frame_ticks = tick_hz / static_cast<std::uint32_t>(build.frame_hz);
  const double frame_us = 1e6 / build.frame_hz;
  for (std::size_t d = 0; d < data.size(); ++d) {
    EXPECT_EQ(data[d].sequence, d);
    if (d > 0) {
      EXPECT_EQ(data[d].timestamp - data[d - 1].timestamp,
                static_cast<std::uint32_t>(build.k) * frame_ticks);
    }
  }
  for (std::size_t i = 0; i < static_cast<std::size_t>(build.sensors); ++i) {
    for (const std::size_t reads : reads_per_frame(s, i)) EXPECT_EQ(reads, build.k);
  }

  // The reads keep to the frame clock, and a frame's timestamp is the
  // tick of its window's last read.
  const std::vector<double>& bursts = s.bench().sensor(0)->burst_times();
  ASSERT_GE(bursts.size(), 2u);
  double worst_latency = 0.0;
  for (const double t : bursts) {
    const double since_tick = std::fmod(t - s.bench().clock_start_us(), frame_us);
    worst_latency = std::max(worst_latency, since_tick);
  }
  const double latency_us = kReadLatencyCycles * 1e6 / build.f_cpu;
  EXPECT_LT(worst_latency, latency_us);
  for (const serial::Data& d : data) {
    const std::size_t last = s.reads_through(0, d.timestamp) - 1;
    const double after_tick = bursts[last] - s.tick_time_us(d.timestamp);
    EXPECT_GE(after_tick, 0.0) << "sequence " << d.sequence;
    EXPECT_LT(after_tick, latency_us) << "sequence " << d.sequence;
  }
  // All N reads of a frame fit in one frame period.
  EXPECT_LT(s.bench().longest_frame_read_us(), frame_us);
}

TEST_P(FirmwareBuilds, SensorsAreCheckedConfiguredAndReadWithinDataSheetTiming) {
  const FirmwareBuild& build = GetParam();
  Session s(build, random_sensors(build.sensors, 100));
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 2; }, kBootUs + 100000.0));
  expect_no_violations(s);
  for (std::size_t i = 0; i < static_cast<std::size_t>(build.sensors); ++i) {
    const std::uint8_t want = build.cpi == 1600 ? 0x19 : 0x09;  // reset value 0x09, bit 4 = 1600
    EXPECT_EQ(s.bench().model<Adns3080Model>(i)->configuration(), want) << "sensor " << i;
  }
}

INSTANTIATE_TEST_SUITE_P(All, FirmwareBuilds, ::testing::ValuesIn(adns_builds()),
                         [](const ::testing::TestParamInfo<FirmwareBuild>& param) {
                           return param.param.name;
                         });

// ------------------------------------------- host commands, Uno build

const FirmwareBuild& build_named(const std::string& name) {
  for (const FirmwareBuild& b : kFirmwareBuilds) {
    if (b.name == name) return b;
  }
  throw std::runtime_error("no firmware build " + name);
}

const FirmwareBuild& uno() { return build_named("moa_firmware_atmega328p"); }

TEST(FirmwareCommands, SetKAnswersHelloAndRegroupsTheFrames) {
  Session s(uno(), random_sensors(uno().sensors, 300));
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 3; }, kBootUs + 100000.0));
  // Mid-window: some reads of the fourth window are already summed.
  s.run_for(5500.0);
  s.send(serial::SetK{5});
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 9; }, 100000.0));

  const std::size_t answer = index_of_nth_hello(s, 1);
  ASSERT_LT(answer, s.received().size());
  EXPECT_EQ(std::get<serial::Hello>(s.received()[answer]).k, 5);
  // The partial window went out before the answer: counts of different
  // settings are never summed, and none are lost.
  ASSERT_TRUE(std::holds_alternative<serial::Data>(s.received()[answer - 1]));
  const std::vector<std::size_t> reads = reads_per_frame(s, 0);
  std::size_t frame = 0;
  for (std::size_t m = 0; m < s.received().size(); ++m) {
    if (!std::holds_alternative<serial::Data>(s.received()[m])) continue;
    if (m < answer - 1) {
      EXPECT_EQ(reads[frame], 12u) << "frame " << frame;
    } else if (m == answer - 1) {
      EXPECT_GT(reads[frame], 0u);
      EXPECT_LT(reads[frame], 12u);
    } else {
      EXPECT_EQ(reads[frame], 5u) << "frame " << frame;
    }
    ++frame;
  }
  const std::vector<serial::Data> data = s.data();
  for (std::size_t d = 0; d < data.size(); ++d) EXPECT_EQ(data[d].sequence, d);
  expect_frames_match_script(s);
  expect_no_violations(s);
}

TEST(FirmwareCommands, SetCpiSetsEverySensorAndAnswersHello) {
  Session s(uno(), random_sensors(uno().sensors, 300));
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 2; }, kBootUs + 100000.0));
  s.send(serial::SetCpi{400});
  ASSERT_TRUE(s.run_until([&] { return s.hellos().size() >= 2; }, 20000.0));
  EXPECT_EQ(s.hellos()[1].cpi, 400);
  for (std::size_t i = 0; i < 4; ++i)
    EXPECT_EQ(s.bench().model<Adns3080Model>(i)->configuration(), 0x09);

  s.send(serial::SetCpi{1600});
  ASSERT_TRUE(s.run_until([&] { return s.hellos().size() >= 3; }, 20000.0));
  EXPECT_EQ(s.hellos()[2].cpi, 1600);
  for (std::size_t i = 0; i < 4; ++i)
    EXPECT_EQ(s.bench().model<Adns3080Model>(i)->configuration(), 0x19);

  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 6; }, 100000.0));
  expect_frames_match_script(s);
  expect_no_violations(s);
}

TEST(FirmwareCommands, RefusedSettingsAnswerHelloUnchanged) {
  Session s(uno(), random_sensors(uno().sensors, 300));
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 1; }, kBootUs + 100000.0));
  s.send(serial::SetK{0});
  ASSERT_TRUE(s.run_until([&] { return s.hellos().size() >= 2; }, 20000.0));
  s.send(serial::SetK{1001});
  ASSERT_TRUE(s.run_until([&] { return s.hellos().size() >= 3; }, 20000.0));
  s.send(serial::SetCpi{800});
  ASSERT_TRUE(s.run_until([&] { return s.hellos().size() >= 4; }, 20000.0));
  for (const serial::Hello& hello : s.hellos()) {
    EXPECT_EQ(hello.k, 12);
    EXPECT_EQ(hello.cpi, 1600);
  }
  for (std::size_t i = 0; i < 4; ++i)
    EXPECT_EQ(s.bench().model<Adns3080Model>(i)->configuration(), 0x19);
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 5; }, 100000.0));
  for (const std::size_t reads : reads_per_frame(s, 0)) EXPECT_EQ(reads, 12u);
  expect_frames_match_script(s);
}

TEST(FirmwareCommands, HelloRequestLeavesTheWindowAlone) {
  Session s(uno(), random_sensors(uno().sensors, 300));
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 2; }, kBootUs + 100000.0));
  s.run_for(4500.0);
  s.send(serial::HelloRequest{});
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 5; }, 100000.0));
  ASSERT_EQ(s.hellos().size(), 2u);
  EXPECT_EQ(s.hellos()[1].k, s.hellos()[0].k);
  EXPECT_EQ(s.hellos()[1].cpi, s.hellos()[0].cpi);
  EXPECT_EQ(s.hellos()[1].names, s.hellos()[0].names);
  for (const std::size_t reads : reads_per_frame(s, 0)) EXPECT_EQ(reads, 12u);
  expect_frames_match_script(s);
}

TEST(FirmwareCommands, CorruptCommandsAreIgnoredAndTheReaderResynchronises) {
  Session s(uno(), random_sensors(uno().sensors, 300));
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 1; }, kBootUs + 100000.0));

  std::vector<std::uint8_t> bad_crc = serial::encode(serial::SetK{5});
  bad_crc[2] ^= 0x01;  // inside the K field; still no zero byte
  ASSERT_NE(bad_crc[2], 0);
  s.send_raw(bad_crc);
  s.run_for(5000.0);
  std::vector<std::uint8_t> overlong(40, 0x55);  // a block longer than any command
  overlong.push_back(0x00);
  s.send_raw(overlong);
  s.run_for(5000.0);
  s.send_raw({0x02, 0x12, 0x00});  // HELLO_REQUEST without its CRC
  s.run_for(5000.0);
  EXPECT_EQ(s.hellos().size(), 1u);

  s.send(serial::HelloRequest{});
  ASSERT_TRUE(s.run_until([&] { return s.hellos().size() >= 2; }, 20000.0));
  EXPECT_EQ(s.hellos()[1].k, 12);
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 4; }, 100000.0));
  for (const std::size_t reads : reads_per_frame(s, 0)) EXPECT_EQ(reads, 12u);
}

TEST(FirmwareCommands, WindowSumsSaturateAtInt16AndSetOverflow) {
  std::vector<SensorSetup> setups = random_sensors(uno().sensors, 400);
  // 120 counts per frame: 300 frames sum to 36000, past int16.
  for (MotionFrame& f : setups[0].script) f = MotionFrame{120, -120, 80, false};
  Session s(uno(), setups);
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 1; }, kBootUs + 100000.0));
  s.send(serial::SetK{300});
  ASSERT_TRUE(s.run_until(
      [&] {
        const std::size_t answer = index_of_nth_hello(s, 1);
        // The first DATA frame after the answer (a STATUS frame follows
        // every HELLO).
        if (answer >= s.received().size()) return false;
        return std::any_of(
            s.received().begin() + static_cast<std::ptrdiff_t>(answer) + 1, s.received().end(),
            [](const serial::Message& m) { return std::holds_alternative<serial::Data>(m); });
      },
      400000.0));
  const serial::Data wide = s.data().back();  // a copy: data() is a temporary
  EXPECT_EQ(wide.sensors[0].dx, 32767);
  EXPECT_EQ(wide.sensors[0].dy, -32768);
  EXPECT_EQ(wide.sensors[0].flags & kFlagOverflow, kFlagOverflow);
  expect_frames_match_script(s);
}

TEST(FirmwareCommands, WindowsTheMainLoopCannotSendInTimeAreMergedNotLost) {
  // At 8 MHz the main loop needs about two frame periods to send a 4-sensor
  // frame (docs/firmware.md, rates): with K = 1 windows close faster than
  // they can leave.
  const FirmwareBuild& build = build_named("moa_firmware_atmega328p_8mhz");
  Session s(build, random_sensors(build.sensors, 400));
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 1; }, kBootUs + 100000.0));
  s.send(serial::SetK{1});
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 60; }, 200000.0));

  expect_frames_match_script(s);  // consecutive sequence numbers: nothing lost
  const std::vector<std::size_t> reads = reads_per_frame(s, 0);
  const std::size_t merged = static_cast<std::size_t>(
      std::count_if(reads.begin() + 2, reads.end(), [](std::size_t r) { return r > 1; }));
  EXPECT_GT(merged, 0u);
  for (std::size_t f = 2; f < reads.size(); ++f) EXPECT_GE(reads[f], 1u) << "frame " << f;
  expect_no_violations(s);
}

TEST(FirmwareCommands, MissingSensorsAreReportedWithoutSurface) {
  std::vector<SensorSetup> setups = random_sensors(uno().sensors, 200);
  setups[2].connected = false;  // nothing on chip select 2: MISO reads 0xFF
  setups[3].product_id = 0x00;  // another part on chip select 3
  Session s(uno(), setups);
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 4; }, kBootUs + 100000.0));
  expect_frames_match_script(s);  // sensors 2 and 3: 0, 0, squal 0, no surface
  // After its product ID read the impostor is left alone.
  EXPECT_EQ(s.bench().sensor(3)->accesses(), 2u);
  EXPECT_EQ(s.bench().model<Adns3080Model>(3)->configuration(), Adns3080Model::kConfigurationReset);
  expect_no_violations(s);
}

// ------------------------------------------------- the gyro (TWI bus)

constexpr double kPi = 3.14159265358979323846;

/// The builds whose TWI pins are free (12 sensors or fewer, config.h).
std::vector<FirmwareBuild> gyro_builds() {
  std::vector<FirmwareBuild> out;
  for (const FirmwareBuild& b : kFirmwareBuilds) {
    if (b.sensors <= 12 && b.sensor == "ADNS3080") out.push_back(b);
  }
  return out;
}

/// rad/s to raw LSB at +-500 deg/s (65.5 LSB per deg/s), unrounded.
double lsb_of(double rate) { return rate * 180.0 / kPi * 65.5; }

/// The gyro samples (the model's ZOUT reads) of each DATA window, in order:
/// a window's samples are those read before the next tick after its
/// timestamp (a frame's reads fit in its period, checked below).
std::vector<std::vector<Mpu6050Model::Sample>> samples_per_window(Session& s) {
  const auto& samples = s.bench().gyro()->samples();
  std::vector<std::vector<Mpu6050Model::Sample>> out;
  std::size_t at = 0;
  for (const serial::Data& d : s.data()) {
    const double end = s.tick_time_us(d.timestamp) + 1e6 / s.build().frame_hz;
    out.emplace_back();
    while (at < samples.size() && samples[at].t_us < end) out.back().push_back(samples[at++]);
  }
  return out;
}

class FirmwareGyro : public ::testing::TestWithParam<FirmwareBuild> {};

TEST_P(FirmwareGyro, GyroFramesCarryTheRateOfTheirDataWindow) {
  const FirmwareBuild& build = GetParam();
  // Counter-clockwise, 0.5 to 1.5 rad/s over a 40 ms period: each window
  // sees a different rate.
  const auto rate = [](double t_us) { return 1.0 + 0.5 * std::sin(2.0 * kPi * t_us / 40000.0); };
  Session s(build, random_sensors(build.sensors, 300), std::make_unique<Mpu6050Model>(rate));
  ASSERT_TRUE(s.run_until([&] { return s.gyros().size() >= 8; }, kBootUs + 200000.0));

  // Set up as gyro.h says: awake, +-500 deg/s, DLPF 2, 1 kHz.
  const Mpu6050Model& model = *s.bench().gyro();
  EXPECT_FALSE(model.asleep());
  EXPECT_EQ(model.register_value(Mpu6050Model::kRegGyroConfig), 0x08);
  EXPECT_EQ(model.register_value(Mpu6050Model::kRegConfig), 0x02);

  // Every DATA frame is followed by the GYRO frame of its window.
  std::size_t pairs = 0;
  for (std::size_t m = 0; m + 1 < s.received().size(); ++m) {
    const auto* d = std::get_if<serial::Data>(&s.received()[m]);
    if (d == nullptr) continue;
    const auto* g = std::get_if<serial::Gyro>(&s.received()[m + 1]);
    ASSERT_NE(g, nullptr) << "no GYRO after DATA " << d->sequence;
    EXPECT_EQ(g->sequence, d->sequence);
    ++pairs;
  }
  EXPECT_GE(pairs, 8u);

  const std::vector<serial::Gyro> gyros = s.gyros();
  const auto windows = samples_per_window(s);
  const double frame_us = 1e6 / build.frame_hz;
  // The gyro read fits the frame with the sensors': no tick is lost.
  const std::vector<serial::Data> data = s.data();
  const std::uint32_t frame_ticks = build.f_cpu / 8u / static_cast<std::uint32_t>(build.frame_hz);
  for (std::size_t d = 1; d < data.size(); ++d) {
    EXPECT_EQ(data[d].timestamp - data[d - 1].timestamp,
              static_cast<std::uint32_t>(build.k) * frame_ticks)
        << d;
  }
  for (std::size_t w = 0; w < gyros.size(); ++w) {
    SCOPED_TRACE("window " + std::to_string(w));
    const serial::Gyro& g = gyros[w];
    ASSERT_EQ(g.n, static_cast<std::uint16_t>(build.k));
    ASSERT_EQ(windows[w].size(), static_cast<std::size_t>(build.k));
    EXPECT_EQ(g.lsb_per_dps_x10, 655);
    EXPECT_EQ(g.flags, 0);
    // Each sample within its frame's period, after the tick: the rate of
    // the same K frames as the counts.
    const double last_tick = s.tick_time_us(s.data()[w].timestamp);
    EXPECT_GE(windows[w].back().t_us, last_tick);
    EXPECT_GE(windows[w].front().t_us, last_tick - (build.k - 1) * frame_us);
    // The programmed rate at the read times, rounded once per sample:
    // within half an LSB each, one LSB per frame in all.
    double want = 0.0;
    for (const auto& sample : windows[w]) want += lsb_of(rate(sample.t_us));
    EXPECT_NEAR(g.sum, want, g.n * 1.0);
    EXPECT_GT(g.sum, 0);  // counter-clockwise is positive
    EXPECT_NEAR(g.rate(), want / g.n / 65.5 * kPi / 180.0, kPi / 180.0 / 65.5);
  }
  expect_frames_match_script(s);
  expect_no_violations(s);
  EXPECT_EQ(s.stats().corrupt, 0u);
}

TEST_P(FirmwareGyro, FullScaleSamplesAreFlaggedSaturated) {
  const FirmwareBuild& build = GetParam();
  // -20 rad/s (-1146 deg/s) for 30 ms, beyond the +-500 deg/s full scale;
  // -1 rad/s (clockwise) before and after.
  const double fast_from = kBootUs + 40000.0;
  const double fast_to = fast_from + 30000.0;
  const auto rate = [&](double t) { return t >= fast_from && t < fast_to ? -20.0 : -1.0; };
  Session s(build, random_sensors(build.sensors, 300), std::make_unique<Mpu6050Model>(rate));
  ASSERT_TRUE(s.run_until([&] { return s.bench().now_us() > fast_to + 30000.0; }, 400000.0));
  const std::vector<serial::Gyro> gyros = s.gyros();
  const auto windows = samples_per_window(s);
  std::size_t saturated = 0;
  ASSERT_GE(windows.size(), gyros.size());
  for (std::size_t w = 0; w < gyros.size(); ++w) {
    ASSERT_EQ(gyros[w].sequence, w);
    const bool fast = std::any_of(windows[w].begin(), windows[w].end(), [&](const auto& x) {
      return x.t_us >= fast_from && x.t_us < fast_to;
    });
    const bool all_fast = std::all_of(windows[w].begin(), windows[w].end(), [&](const auto& x) {
      return x.t_us >= fast_from && x.t_us < fast_to;
    });
    EXPECT_EQ(gyros[w].flags, fast ? serial::kGyroSaturated : 0) << w;
    EXPECT_LT(gyros[w].sum, 0) << w;
    if (all_fast) {
      EXPECT_EQ(gyros[w].sum, -32768 * static_cast<int>(gyros[w].n)) << w;
      ++saturated;
    }
  }
  EXPECT_GE(saturated, 1u);
}

INSTANTIATE_TEST_SUITE_P(WithTwi, FirmwareGyro, ::testing::ValuesIn(gyro_builds()),
                         [](const ::testing::TestParamInfo<FirmwareBuild>& param) {
                           return param.param.name;
                         });

TEST(FirmwareGyroFaults, AnotherChipOrNoneMeansNoGyroFramesAndTheMiceAsBefore) {
  // WHO_AM_I 0x70 (an MPU-6500): not the part the firmware knows.
  Session other(uno(), random_sensors(uno().sensors, 200),
                std::make_unique<Mpu6050Model>([](double) { return 1.0; }, 0x70));
  ASSERT_TRUE(other.run_until([&] { return other.data().size() >= 6; }, kBootUs + 100000.0));
  EXPECT_TRUE(other.gyros().empty());
  EXPECT_TRUE(other.bench().gyro()->writes().empty());  // left asleep, untouched
  EXPECT_TRUE(other.bench().gyro()->samples().empty());
  expect_frames_match_script(other);

  Session none(uno(), random_sensors(uno().sensors, 200));
  ASSERT_TRUE(none.run_until([&] { return none.data().size() >= 6; }, kBootUs + 100000.0));
  EXPECT_TRUE(none.gyros().empty());
  expect_frames_match_script(none);
  EXPECT_EQ(none.stats().corrupt + other.stats().corrupt, 0u);
}

TEST(FirmwareGyroFaults, AHungBusStopsTheGyroFramesAndNotTheMice) {
  Session s(uno(), random_sensors(uno().sensors, 400),
            std::make_unique<Mpu6050Model>([](double) { return 0.5; }));
  ASSERT_TRUE(s.run_until([&] { return s.gyros().size() >= 3; }, kBootUs + 100000.0));
  const double hang_us = s.bench().now_us() + 5300.0;  // inside a window
  s.bench().gyro()->hold_bus_from(hang_us);
  const std::size_t gyros_before = s.gyros().size();
  const std::size_t data_before = s.data().size();
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= data_before + 10; }, 200000.0));

  // The mice: every window whole, K reads each, timestamps K frames apart.
  expect_frames_match_script(s);
  for (const std::size_t reads : reads_per_frame(s, 0)) EXPECT_EQ(reads, 12u);
  const std::vector<serial::Data> data = s.data();
  for (std::size_t d = 1; d < data.size(); ++d) {
    EXPECT_EQ(data[d].timestamp - data[d - 1].timestamp, 12u * 2000u) << d;
  }
  // The gyro: at most the window of the hang still has a frame (with the
  // samples read before it), none after.
  const std::vector<serial::Gyro> gyros = s.gyros();
  EXPECT_LE(gyros.size(), gyros_before + 2);
  ASSERT_FALSE(gyros.empty());
  EXPECT_LT(s.tick_time_us(data[gyros.back().sequence].timestamp) - 12000.0, hang_us);
  for (const auto& sample : s.bench().gyro()->samples()) EXPECT_LT(sample.t_us, hang_us);
  // One timeout, not one per frame: the step that hung (a write), the
  // module switched off and on (two), then the gyro is left alone.
  EXPECT_EQ(s.bench().twcr_writes_while_held(), 3u);
  expect_no_violations(s);
}

}  // namespace
}  // namespace moa::firmware_sim
