// The serial reader (io/serial_reader.hpp) through a pseudo-terminal: a test
// thread plays the microcontroller (docs/serial-protocol.md) on the master
// side with good, corrupt, truncated, lost and random frames.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "moa/formats/config.hpp"
#include "moa/formats/error.hpp"
#include "moa/sources/serial_reader.hpp"
#include "support/error_of.hpp"
#include "support/pty.hpp"
#include "support/synth.hpp"

namespace moa::io {
namespace {

using Bytes = std::vector<std::uint8_t>;
using serial::Data;
using serial::Hello;

using test::error_of;

RobotConfig two_sensors() {
  return parse_config(
      "version: 1\n"
      "sensors:\n"
      "  - {name: a, position: [0.1, 0], yaw: 0, cpi: 800}\n"
      "  - {name: b, position: [-0.1, 0], yaw: 0, cpi: 800}\n",
      "robot.yaml");
}

Hello hello_ba(std::uint16_t k = 4, std::uint16_t rate = 400) {
  Hello h;
  h.k = k;
  h.frame_rate = rate;
  h.cpi = 800;
  h.tick_hz = 1000000;
  h.names = {"b", "a"};  // the device's order differs from the config's
  return h;
}

Data data(std::uint16_t sequence, std::uint32_t timestamp, std::int16_t b_dx, std::int16_t a_dy) {
  Data d;
  d.sequence = sequence;
  d.timestamp = timestamp;
  d.n = 2;
  d.sensors[0] = {b_dx, 1, 90, 0};
  d.sensors[1] = {-3, a_dy, 40, 1};
  return d;
}

SerialOptions fast_options() {
  SerialOptions options;
  options.baud = 230400;
  options.start_timeout = 5.0;
  return options;
}

LiveHooks collecting(std::vector<std::string>& warnings) {
  LiveHooks hooks;
  hooks.tick_period = 0.01;
  hooks.warn = [&warnings](const std::string& w) { warnings.push_back(w); };
  return hooks;
}

bool contains_text(const std::vector<std::string>& lines, const std::string& text) {
  for (const auto& line : lines) {
    if (line.find(text) != std::string::npos) return true;
  }
  return false;
}

// Reads rows until the stream ends, counting them for the device thread.
std::vector<SensorRow> read_rows(SerialReader& reader, std::atomic<int>& seen) {
  std::vector<SensorRow> rows;
  while (const auto row = reader.next()) {
    rows.push_back(*row);
    ++seen;
  }
  return rows;
}

void wait_for(const std::atomic<int>& seen, int count) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (seen.load() < count && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  // Let the reader's next poll see nothing more before the hang-up.
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
}

TEST(SerialReader, StreamsRowsAndCountsLostAndCorruptFrames) {
  test::PseudoTerminal pty;
  std::vector<std::string> warnings;
  std::atomic<int> seen{0};
  SerialReader reader(pty.device(), two_sensors(), fast_options(), collecting(warnings));

  // What the test sends, and what should arrive: frames 20 (corrupted on
  // the line) and 30 (never sent) are lost; their counts with them.
  const int n_frames = 100;
  std::int64_t sum_b_dx = 0, sum_a_dy = 0;
  std::vector<double> times;
  std::thread device([&] {
    ASSERT_TRUE(pty.wait_for_hello_request(5.0));
    pty.write(serial::encode(hello_ba()));
    std::mt19937 rng(1);
    std::uniform_int_distribution<int> byte(1, 255);
    for (int k = 0; k < n_frames; ++k) {
      const auto d = data(static_cast<std::uint16_t>(k), 1'000'000u + 10'000u * k,
                          static_cast<std::int16_t>(k - 50), static_cast<std::int16_t>(2 * k));
      Bytes wire = serial::encode(d);
      if (k == 10) {
        // Garbage between frames: one corrupt block, then in step again.
        Bytes garbage{0};
        for (int i = 0; i < 40; ++i) garbage.push_back(static_cast<std::uint8_t>(byte(rng)));
        garbage.push_back(0);
        pty.write(garbage);
      }
      if (k == 30) continue;
      if (k == 20) {
        wire[5] = static_cast<std::uint8_t>(wire[5] == 0x55 ? 0x56 : 0x55);
      }
      pty.write(wire);
    }
    wait_for(seen, 2 * (n_frames - 2));
    pty.close_master();
  });
  EXPECT_EQ(reader.start_time(), 0.0);
  const auto rows = read_rows(reader, seen);
  device.join();

  for (int k = 0; k < n_frames; ++k) {
    if (k == 20 || k == 30) continue;
    sum_b_dx += k - 50;
    sum_a_dy += 2 * k;
    // Rows are relative to the first window's start: K / rate = 10 ms
    // before the first frame's timestamp.
    times.push_back(0.01 + 0.01 * k);
  }
  ASSERT_EQ(rows.size(), 2u * (n_frames - 2));
  std::int64_t got_b_dx = 0, got_a_dy = 0, got_a_dx = 0;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const SensorRow& row = rows[i];
    EXPECT_NEAR(row.t, times[i / 2], 1e-9) << i;
    if (row.sensor == 1) {  // "b" is the config's second sensor
      got_b_dx += static_cast<std::int64_t>(row.counts.x());
      EXPECT_EQ(row.squal, 90);
      EXPECT_EQ(row.flags, 0);
    } else {
      ASSERT_EQ(row.sensor, 0);
      got_a_dy += static_cast<std::int64_t>(row.counts.y());
      got_a_dx += static_cast<std::int64_t>(row.counts.x());
      EXPECT_EQ(row.squal, 40);
      EXPECT_EQ(row.flags, 1);
    }
  }
  EXPECT_EQ(got_b_dx, sum_b_dx);
  EXPECT_EQ(got_a_dy, sum_a_dy);
  EXPECT_EQ(got_a_dx, -3 * (n_frames - 2));
  const auto& stats = reader.stats();
  EXPECT_EQ(stats.data_frames, static_cast<std::uint64_t>(n_frames - 2));
  EXPECT_EQ(stats.lost_frames, 2u);
  EXPECT_EQ(stats.corrupt, 2u);  // the garbage block and frame 20
  EXPECT_EQ(stats.overflow_rows, static_cast<std::uint64_t>(n_frames - 2));
  EXPECT_EQ(reader.hello().names, (std::vector<std::string>{"b", "a"}));
  EXPECT_TRUE(contains_text(warnings, "DATA frames lost so far")) << warnings.size();
  EXPECT_TRUE(contains_text(warnings, "corrupt frames so far"));
  EXPECT_TRUE(contains_text(warnings, pty.device() + ": device lost ("));
}

serial::Gyro gyro_frame(std::uint16_t sequence, std::int32_t sum, std::uint8_t flags = 0) {
  serial::Gyro g;
  g.sequence = sequence;
  g.sum = sum;
  g.n = 4;  // K of hello_ba()
  g.lsb_per_dps_x10 = 655;
  g.flags = flags;
  return g;
}

TEST(SerialReader, GyroFramesBecomeSamplesAtTheirDataFramesTime) {
  test::PseudoTerminal pty;
  std::vector<std::string> warnings;
  std::atomic<int> seen{0};
  SerialReader reader(pty.device(), two_sensors(), fast_options(), collecting(warnings));
  // Frame k's gyro sum: 4 samples of (300 k - 3000) LSB, clockwise first.
  const auto sum_of = [](int k) { return 4 * (300 * k - 3000); };
  const int n_frames = 20;
  std::thread device([&] {
    ASSERT_TRUE(pty.wait_for_hello_request(5.0));
    pty.write(serial::encode(hello_ba()));
    for (int k = 0; k < n_frames; ++k) {
      const auto sequence = static_cast<std::uint16_t>(k);
      pty.write(serial::encode(data(sequence, 1'000'000u + 10'000u * k, 1, 1)));
      Bytes gyro = serial::encode(gyro_frame(sequence, sum_of(k), k == 9 ? 1 : 0));
      if (k == 5) gyro.resize(gyro.size() / 2);  // cut off: the rest of it lost on the line
      if (k == 5) gyro.push_back(0);
      if (k == 7) gyro[4] = static_cast<std::uint8_t>(gyro[4] == 0x55 ? 0x56 : 0x55);
      if (k == 12) gyro = serial::encode(gyro_frame(11, sum_of(k)));  // names another frame
      // Time for the reader to take the DATA frame alone: its rows must
      // still wait for the sample.
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
      pty.write(gyro);
    }
    wait_for(seen, 2 * n_frames);
    pty.close_master();
  });
  reader.start_time();
  std::vector<SensorRow> rows;
  std::vector<GyroSample> samples;
  // Whether the sample of a row's window was there when next() gave the row.
  std::vector<bool> sample_first;
  while (const auto row = reader.next()) {
    rows.push_back(*row);
    ++seen;
    for (const GyroSample& g : reader.take_gyro()) samples.push_back(g);
    sample_first.push_back(!samples.empty() && samples.back().t == row->t);
  }
  for (const GyroSample& g : reader.take_gyro()) samples.push_back(g);
  device.join();
  // From the first GYRO frame on, a frame's rows wait for its sample.
  for (std::size_t i = 2; i < rows.size(); ++i) {
    const std::size_t k = i / 2;
    if (k != 5 && k != 7 && k != 12) {
      EXPECT_TRUE(sample_first[i]) << "row " << i;
    }
  }

  ASSERT_EQ(rows.size(), 2u * n_frames);
  std::vector<int> frames;
  for (int k = 0; k < n_frames; ++k) {
    if (k != 5 && k != 7 && k != 12) frames.push_back(k);
  }
  ASSERT_EQ(samples.size(), frames.size());
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const int k = frames[i];
    SCOPED_TRACE("frame " + std::to_string(k));
    // On the rows' clock: the time of the rows of its DATA frame.
    EXPECT_EQ(samples[i].t, rows[2 * static_cast<std::size_t>(k)].t);
    // (300 k - 3000) LSB / 65.5 LSB per deg/s, in rad/s.
    EXPECT_NEAR(samples[i].gz, (300.0 * k - 3000.0) / 65.5 * 3.14159265358979 / 180.0, 1e-12);
    EXPECT_EQ(samples[i].saturated, k == 9);
  }
  const auto& stats = reader.stats();
  EXPECT_EQ(stats.gyro_frames, frames.size());
  EXPECT_EQ(stats.corrupt, 2u);  // frames 5 (cut) and 7 (bad CRC)
  EXPECT_EQ(stats.gyro_unmatched, 1u);
  EXPECT_EQ(stats.gyro_saturated, 1u);
  EXPECT_EQ(stats.lost_frames, 0u);
  EXPECT_TRUE(contains_text(warnings, "GYRO frames without their DATA frame"));
  EXPECT_TRUE(contains_text(warnings, "gyro samples saturated"));
}

TEST(SerialReader, FramesOfAnUnknownTypeAreSkippedNotCorrupt) {
  test::PseudoTerminal pty;
  std::vector<std::string> warnings;
  std::atomic<int> seen{0};
  SerialReader reader(pty.device(), two_sensors(), fast_options(), collecting(warnings));
  std::thread device([&] {
    ASSERT_TRUE(pty.wait_for_hello_request(5.0));
    pty.write(serial::encode(hello_ba()));
    // Type 0x7E, well framed: what a newer firmware might add.
    Bytes payload{0x7E, 1, 2, 3};
    const std::uint16_t crc = serial::crc16(payload);
    payload.push_back(static_cast<std::uint8_t>(crc & 0xFF));
    payload.push_back(static_cast<std::uint8_t>(crc >> 8));
    Bytes unknown = serial::cobs_encode(payload);
    unknown.push_back(0);
    for (int k = 0; k < 5; ++k) {
      pty.write(serial::encode(data(static_cast<std::uint16_t>(k), 10'000u * k, 1, 1)));
      pty.write(unknown);
    }
    wait_for(seen, 10);
    pty.close_master();
  });
  reader.start_time();
  const auto rows = read_rows(reader, seen);
  device.join();
  EXPECT_EQ(rows.size(), 10u);
  EXPECT_EQ(reader.stats().unknown, 5u);
  EXPECT_EQ(reader.stats().corrupt, 0u);
  EXPECT_EQ(reader.stats().lost_frames, 0u);
  EXPECT_TRUE(reader.take_gyro().empty());
  EXPECT_FALSE(contains_text(warnings, "corrupt"));
  EXPECT_TRUE(contains_text(warnings, "of a type this moa does not know"));
}

TEST(SerialReader, JoinsAfterRandomBytesAndSkipsDataBeforeHello) {
  test::PseudoTerminal pty;
  std::vector<std::string> warnings;
  std::atomic<int> seen{0};
  SerialReader reader(pty.device(), two_sensors(), fast_options(), collecting(warnings));
  std::thread device([&] {
    ASSERT_TRUE(pty.wait_for_hello_request(5.0));
    std::mt19937 rng(2);
    std::uniform_int_distribution<int> byte(0, 255);
    Bytes noise(5000);
    for (auto& b : noise) b = static_cast<std::uint8_t>(byte(rng));
    noise.push_back(0);
    pty.write(noise);
    pty.write(serial::encode(data(7, 500, 1, 1)));  // before any HELLO: unusable
    pty.write(serial::encode(hello_ba(1, 0)));      // rate unknown: no window
    for (int k = 0; k < 5; ++k) {
      pty.write(serial::encode(data(static_cast<std::uint16_t>(8 + k), 1000u * k, 4, 5)));
    }
    wait_for(seen, 10);
    pty.close_master();
  });
  reader.start_time();
  const auto rows = read_rows(reader, seen);
  device.join();
  ASSERT_EQ(rows.size(), 10u);
  EXPECT_EQ(rows.front().t, 0.0);
  EXPECT_NEAR(rows.back().t, 0.004, 1e-12);
  EXPECT_EQ(reader.stats().before_hello, 1u);
  EXPECT_EQ(reader.stats().lost_frames, 0u);
}

TEST(SerialReader, DeviceClockSteppingBackIsRebasedAndWrapsAreUnwrapped) {
  test::PseudoTerminal pty;
  std::vector<std::string> warnings;
  std::atomic<int> seen{0};
  SerialReader reader(pty.device(), two_sensors(), fast_options(), collecting(warnings));
  const std::vector<std::uint32_t> stamps{4294960000u, 4294965000u, 2704u, 7704u, 100u, 5100u};
  std::thread device([&] {
    ASSERT_TRUE(pty.wait_for_hello_request(5.0));
    pty.write(serial::encode(hello_ba(1, 200)));  // 5 ms windows
    for (std::size_t k = 0; k < stamps.size(); ++k) {
      pty.write(serial::encode(data(static_cast<std::uint16_t>(k), stamps[k], 1, 1)));
    }
    wait_for(seen, 12);
    pty.close_master();
  });
  reader.start_time();
  const auto rows = read_rows(reader, seen);
  device.join();
  ASSERT_EQ(rows.size(), 12u);
  // 5 ms window, then 5 ms steps across the 2^32 wrap; then the clock
  // restarts (7704 -> 100): that frame is put one window after the previous
  // one (at the same time, its rows would read as duplicates), and the next
  // follows 5 ms later.
  const std::vector<double> expected{0.005, 0.010, 0.015, 0.020, 0.025, 0.030};
  for (std::size_t i = 0; i < rows.size(); ++i) EXPECT_NEAR(rows[i].t, expected[i / 2], 1e-9) << i;
  EXPECT_EQ(reader.stats().clock_steps, 1u);
  EXPECT_TRUE(contains_text(warnings, "1 device clock steps so far"));
}

// What a device can send besides an orderly stream, one case each: the
// frames as sent (HELLO frames between them where `hello_before` says), and
// the frames whose rows must arrive, in order. Every case must give rows
// whose times rise strictly (a recording of them replays: no two rows of a
// sensor at one time) and whose counts are those of the frames kept.
struct DeviceCase {
  const char* name;
  std::vector<Data> frames;
  std::vector<std::size_t> hello_before;  // indices of frames preceded by a new HELLO
  std::vector<std::size_t> kept;          // indices of frames whose rows must arrive
  std::uint64_t duplicates = 0, stale = 0, restarts = 0, clock_steps = 0;
};

std::vector<DeviceCase> device_cases() {
  // 5 ms windows (k = 1 at 200 Hz) at 1 MHz ticks: 5000 ticks a frame.
  const auto at = [](int sequence, std::uint32_t ticks, std::int16_t dx) {
    return data(static_cast<std::uint16_t>(sequence), ticks, dx, 1);
  };
  return {
      {"DuplicatedFrame",
       {at(0, 0, 1), at(1, 5000, 2), at(1, 5000, 2), at(2, 10000, 3)},
       {},
       {0, 1, 3},
       1,
       0,
       0,
       0},
      {"StaleFrame",
       {at(0, 0, 1), at(1, 5000, 2), at(2, 10000, 3), at(1, 5000, 2), at(3, 15000, 4)},
       {},
       {0, 1, 2, 4},
       0,
       1,
       0,
       0},
      {"RestartWithHello",
       {at(100, 900000, 1), at(101, 905000, 2), at(0, 0, 3), at(1, 5000, 4)},
       {2},
       {0, 1, 2, 3},
       0,
       0,
       1,
       0},
      {"RestartWithoutHello",
       {at(100, 900000, 1), at(101, 905000, 2), at(0, 0, 3), at(1, 5000, 4), at(2, 10000, 5)},
       {},
       {0, 1, 3, 4},
       0,
       1,
       1,
       0},
      {"ClockStepsForward4000s",
       {at(0, 0, 1), at(1, 5000, 2), at(2, 4000005000u, 3), at(3, 4000010000u, 4)},
       {},
       {0, 1, 2, 3},
       0,
       0,
       0,
       1},
  };
}

class SerialDeviceCase : public ::testing::TestWithParam<DeviceCase> {};

TEST_P(SerialDeviceCase, RowsKeepRisingAndCarryTheFramesKept) {
  const DeviceCase& c = GetParam();
  test::PseudoTerminal pty;
  std::vector<std::string> warnings;
  std::atomic<int> seen{0};
  SerialReader reader(pty.device(), two_sensors(), fast_options(), collecting(warnings));
  std::thread device([&] {
    ASSERT_TRUE(pty.wait_for_hello_request(5.0));
    pty.write(serial::encode(hello_ba(1, 200)));
    for (std::size_t k = 0; k < c.frames.size(); ++k) {
      if (std::find(c.hello_before.begin(), c.hello_before.end(), k) != c.hello_before.end()) {
        pty.write(serial::encode(hello_ba(1, 200)));
      }
      pty.write(serial::encode(c.frames[k]));
    }
    wait_for(seen, static_cast<int>(2 * c.kept.size()));
    pty.close_master();
  });
  reader.start_time();
  const auto rows = read_rows(reader, seen);
  device.join();
  ASSERT_EQ(rows.size(), 2 * c.kept.size());
  for (std::size_t j = 0; j < c.kept.size(); ++j) {
    const Data& sent = c.frames[c.kept[j]];
    // Device record 0 is sensor 'b' (config index 1), record 1 is 'a'.
    EXPECT_EQ(rows[2 * j].sensor, 1);
    EXPECT_EQ(rows[2 * j].counts.x(), sent.sensors[0].dx) << j;
    EXPECT_EQ(rows[2 * j + 1].counts.y(), sent.sensors[1].dy) << j;
    EXPECT_EQ(rows[2 * j].t, rows[2 * j + 1].t);
    if (j > 0) {
      // Strictly later, by at most one window plus the slack allowed.
      EXPECT_GT(rows[2 * j].t, rows[2 * j - 2].t) << j;
      EXPECT_LE(rows[2 * j].t - rows[2 * j - 2].t, 0.005 + 0.5 + 1e-9) << j;
    }
  }
  EXPECT_EQ(reader.stats().duplicates, c.duplicates);
  EXPECT_EQ(reader.stats().stale, c.stale);
  EXPECT_EQ(reader.stats().restarts, c.restarts);
  EXPECT_EQ(reader.stats().clock_steps, c.clock_steps);
  EXPECT_EQ(contains_text(warnings, "duplicated DATA frames dropped"), c.duplicates > 0);
  EXPECT_EQ(contains_text(warnings, "the device restarted"), c.restarts > 0);
}

INSTANTIATE_TEST_SUITE_P(Cases, SerialDeviceCase, ::testing::ValuesIn(device_cases()),
                         [](const auto& param_info) { return std::string(param_info.param.name); });

TEST(SerialReader, DataWithAnotherSensorCountIsDropped) {
  test::PseudoTerminal pty;
  std::vector<std::string> warnings;
  std::atomic<int> seen{0};
  SerialReader reader(pty.device(), two_sensors(), fast_options(), collecting(warnings));
  std::thread device([&] {
    ASSERT_TRUE(pty.wait_for_hello_request(5.0));
    pty.write(serial::encode(hello_ba()));
    pty.write(serial::encode(data(0, 0, 1, 1)));
    Data three = data(1, 10000, 1, 1);
    three.n = 3;
    pty.write(serial::encode(three));
    pty.write(serial::encode(data(2, 20000, 1, 1)));
    wait_for(seen, 4);
    pty.close_master();
  });
  reader.start_time();
  EXPECT_EQ(read_rows(reader, seen).size(), 4u);
  device.join();
  EXPECT_EQ(reader.stats().mismatched, 1u);
  EXPECT_EQ(reader.stats().lost_frames, 0u);  // sequence 1 arrived, though unusable
}

TEST(SerialReader, SetsThePortRawAtTheBaudRate) {
  test::PseudoTerminal pty;
  SerialReader reader(pty.device(), two_sensors(), fast_options(), {});
  termios tio{};
  ASSERT_EQ(::tcgetattr(pty.slave_fd(), &tio), 0);
  EXPECT_EQ(::cfgetispeed(&tio), static_cast<speed_t>(B230400));
  EXPECT_EQ(::cfgetospeed(&tio), static_cast<speed_t>(B230400));
  EXPECT_EQ(tio.c_lflag & (ICANON | ECHO | ISIG), 0u);
  EXPECT_EQ(tio.c_iflag & (IXON | ICRNL | INLCR), 0u);
  EXPECT_EQ(tio.c_oflag & OPOST, 0u);
  EXPECT_EQ(tio.c_cflag & CSIZE, static_cast<tcflag_t>(CS8));
  EXPECT_EQ(tio.c_cflag & (PARENB | CSTOPB), 0u);
  EXPECT_NE(tio.c_cflag & CLOCAL, 0u);
}

TEST(SerialReader, SendsHostCommandsAsFrames) {
  test::PseudoTerminal pty;
  SerialReader reader(pty.device(), two_sensors(), fast_options(), {});
  reader.send(serial::HelloRequest{});
  EXPECT_TRUE(pty.wait_for_hello_request(2.0));
}

TEST(SerialReader, SensorTheConfigLacksIsAnError) {
  test::PseudoTerminal pty;
  SerialReader reader(pty.device(), two_sensors(), fast_options(), {});
  std::thread device([&] {
    ASSERT_TRUE(pty.wait_for_hello_request(5.0));
    Hello h = hello_ba();
    h.names = {"a", "zz"};
    pty.write(serial::encode(h));
  });
  EXPECT_EQ(error_of([&] { reader.start_time(); }),
            pty.device() +
                ": the device names sensor 'zz', which the robot config does not have (config "
                "sensors: a, b)");
  device.join();
}

// A HELLO naming one sensor twice (m1,m1,m1 was taken: a wrong pose, two
// sensors that never reported, a recording that did not replay) is refused
// saying which and where (issue #47, item 4).
TEST(SerialReader, AHelloNamingASensorTwiceIsAnError) {
  test::PseudoTerminal pty;
  SerialReader reader(pty.device(), two_sensors(), fast_options(), {});
  std::thread device([&] {
    ASSERT_TRUE(pty.wait_for_hello_request(5.0));
    Hello h = hello_ba();
    h.names = {"b", "a", "b"};
    pty.write(serial::encode(h));
  });
  EXPECT_EQ(error_of([&] { reader.start_time(); }),
            pty.device() +
                ": the device's HELLO names sensor 'b' twice (records 1 and 3 of 3: b,a,b): each "
                "sensor reports once");
  device.join();
}

// A HELLO whose cpi is not the config's (400 against 800) is said, once, with
// the sensors it differs for; the config's cpi reads the counts.
TEST(SerialReader, AHelloCpiUnlikeTheConfigsIsWarnedOnce) {
  test::PseudoTerminal pty;
  std::vector<std::string> warnings;
  std::atomic<int> seen{0};
  SerialReader reader(pty.device(), two_sensors(), fast_options(), collecting(warnings));
  std::thread device([&] {
    ASSERT_TRUE(pty.wait_for_hello_request(5.0));
    Hello h = hello_ba();
    h.cpi = 400;
    pty.write(serial::encode(h));
    for (int k = 0; k < 3; ++k) {
      pty.write(serial::encode(data(static_cast<std::uint16_t>(k), 10'000u * (k + 1), 1, 2)));
    }
    wait_for(seen, 6);
    pty.close_master();
  });
  reader.start_time();
  const auto rows = read_rows(reader, seen);
  device.join();
  EXPECT_EQ(rows.size(), 6u);
  std::size_t said = 0;
  for (const auto& w : warnings) {
    if (w.find("cpi") == std::string::npos) continue;
    ++said;
    EXPECT_EQ(w, pty.device() +
                     ": the device's HELLO says 400 cpi but the robot config has 'b' 800, 'a' "
                     "800: the config's cpi reads the counts, so a device at 400 cpi reads its "
                     "motion off by their ratio");
  }
  EXPECT_EQ(said, 1u);
}

// STATUS frames: each sensor that is not ok is said once, by its name and
// chip select, with the reason; the rows of the others go on.
TEST(SerialReader, SensorStatesOtherThanOkAreWarnedOncePerChange) {
  test::PseudoTerminal pty;
  std::vector<std::string> warnings;
  std::atomic<int> seen{0};
  SerialReader reader(pty.device(), two_sensors(), fast_options(), collecting(warnings));
  std::thread device([&] {
    ASSERT_TRUE(pty.wait_for_hello_request(5.0));
    pty.write(serial::encode(hello_ba()));
    serial::Status st;
    st.n = 2;
    st.sensors[1] = {2, 0x47};
    pty.write(serial::encode(st));
    pty.write(serial::encode(st));  // the same again: nothing new to say
    pty.write(serial::encode(data(0, 10'000u, 1, 1)));
    st.sensors[1] = {5, 0};
    pty.write(serial::encode(st));
    pty.write(serial::encode(data(1, 20'000u, 1, 1)));
    wait_for(seen, 4);
    pty.close_master();
  });
  reader.start_time();
  const auto rows = read_rows(reader, seen);
  device.join();
  EXPECT_EQ(rows.size(), 4u);
  std::vector<std::string> said;
  for (const auto& w : warnings) {
    if (w.find("chip select") != std::string::npos) said.push_back(w);
  }
  ASSERT_EQ(said.size(), 2u);
  EXPECT_EQ(
      said[0],
      pty.device() + ": sensor 'a' (chip select 2): another part (product ID 0x47), left alone");
  EXPECT_EQ(said[1], pty.device() +
                         ": sensor 'a' (chip select 2): stopped answering; not read until the "
                         "device restarts");
  EXPECT_EQ(reader.stats().unknown, 0u);
}

TEST(SerialReader, SilentDeviceTimesOutAfterAskingForHello) {
  test::PseudoTerminal pty;
  SerialOptions options = fast_options();
  options.start_timeout = 0.3;
  SerialReader reader(pty.device(), two_sensors(), options, {});
  std::atomic<bool> asked{false};
  std::thread device([&] { asked = pty.wait_for_hello_request(2.0); });
  EXPECT_EQ(error_of([&] { reader.start_time(); }),
            pty.device() +
                ": no HELLO from the device within 0.3 s (0 bytes, 0 corrupt frames received; "
                "wrong port or baud rate?)");
  device.join();
  EXPECT_TRUE(asked.load());
}

TEST(SerialReader, StopBeforeStreamingIsAnError) {
  test::PseudoTerminal pty;
  LiveHooks hooks;
  hooks.stop = [] { return true; };
  SerialReader reader(pty.device(), two_sensors(), fast_options(), hooks);
  EXPECT_EQ(error_of([&] { reader.start_time(); }),
            pty.device() + ": stopped before the device started streaming");
}

TEST(SerialReader, HangUpBeforeStreamingIsAnError) {
  test::PseudoTerminal pty;
  SerialReader reader(pty.device(), two_sensors(), fast_options(), {});
  pty.close_master();
  const std::string error = error_of([&] { reader.start_time(); });
  EXPECT_EQ(error, pty.device() + ": device lost before it started streaming");
}

TEST(SerialReader, PortErrorsAreNamed) {
  const auto dir = test::scratch_dir("serial-bad");
  const auto file = dir / "not-a-port";
  std::ofstream(file) << "x";
  EXPECT_EQ(error_of([&] { SerialReader r(file, two_sensors(), fast_options(), {}); }),
            file.string() + ": not a serial port (tcgetattr: " + std::strerror(ENOTTY) + ")");
  const auto missing = dir / "ttyUSB9";
  EXPECT_EQ(error_of([&] { SerialReader r(missing, two_sensors(), fast_options(), {}); }),
            missing.string() + ": cannot open (" + std::strerror(ENOENT) + ")");
  test::PseudoTerminal pty;
  SerialOptions odd = fast_options();
  odd.baud = 12345;
  EXPECT_EQ(error_of([&] { SerialReader r(pty.device(), two_sensors(), odd, {}); }),
            pty.device() + ": baud rate 12345 is not supported");
  std::filesystem::remove_all(dir);
}

TEST(SerialReader, ReadsACapturedStreamFromAFile) {
  // configure_port off: a file of captured bytes replays like a port.
  const auto dir = test::scratch_dir("serial-file");
  const auto file = dir / "capture.bin";
  {
    std::ofstream out(file, std::ios::binary);
    for (const auto& wire : {serial::encode(hello_ba(2, 200)), serial::encode(data(0, 0, 5, 6)),
                             serial::encode(data(1, 10000, 7, 8))}) {
      out.write(reinterpret_cast<const char*>(wire.data()),
                static_cast<std::streamsize>(wire.size()));
    }
  }
  SerialOptions options;
  options.configure_port = false;
  SerialReader reader(file, two_sensors(), options, {});
  std::atomic<int> seen{0};
  const auto rows = read_rows(reader, seen);
  ASSERT_EQ(rows.size(), 4u);
  EXPECT_NEAR(rows[0].t, 0.01, 1e-12);
  EXPECT_NEAR(rows[2].t, 0.02, 1e-12);
  EXPECT_EQ(rows[2].counts.x() + rows[0].counts.x(), 12.0);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace moa::io
