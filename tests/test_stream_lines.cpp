// The robot's streams while live (sources/stream_lines.hpp): each line's
// parse, every bad line's kind, and their merge into a live run
// (io::LiveRunSource): a recorded run with wheel rows replays to the same
// steps.
#include <arpa/inet.h>
#include <fmt/core.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "moa/formats/config.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/log.hpp"
#include "moa/formats/stream_csv.hpp"
#include "moa/runs/live_source.hpp"
#include "moa/runs/odometry_run.hpp"
#include "moa/runs/run_loop.hpp"
#include "moa/sources/stream_lines.hpp"
#include "support/http.hpp"
#include "support/synth.hpp"

namespace moa::io {
namespace {

namespace fs = std::filesystem;
using E = StreamLineError;

StreamRow good(std::string_view line) {
  auto parsed = parse_stream_line(line);
  EXPECT_TRUE(std::holds_alternative<StreamRow>(parsed)) << line;
  return std::holds_alternative<StreamRow>(parsed) ? std::get<StreamRow>(parsed) : StreamRow{};
}

std::optional<E> bad(std::string_view line) {
  const auto parsed = parse_stream_line(line);
  if (const auto* e = std::get_if<E>(&parsed)) return *e;
  return std::nullopt;
}

TEST(StreamLines, AWheelLineIsTheTwistOfWheelsCsvWithOrWithoutItsTime) {
  StreamRow r = good("wheels,12.5,0.25,-0.125,1.5");
  EXPECT_TRUE(r.stamped);
  const auto& w = std::get<WheelRow>(r.row);
  EXPECT_EQ(w.t, 12.5);
  EXPECT_EQ(w.twist.v.x(), 0.25);
  EXPECT_EQ(w.twist.v.y(), -0.125);
  EXPECT_EQ(w.twist.omega, 1.5);
  r = good(" wheels , ,1,2,3\r");
  EXPECT_FALSE(r.stamped);
  EXPECT_EQ(std::get<WheelRow>(r.row).twist.omega, 3.0);
}

TEST(StreamLines, ACameraLineHasOptionalHeadingAndStandardDeviations) {
  CameraFix f = std::get<CameraFix>(good("camera,1,2,3").row);
  EXPECT_EQ(f.t, 1.0);
  EXPECT_EQ(f.position.x(), 2.0);
  EXPECT_EQ(f.position.y(), 3.0);
  EXPECT_FALSE(f.theta);
  EXPECT_FALSE(f.sigma);
  f = std::get<CameraFix>(good("camera,,2,3,0.5").row);
  EXPECT_EQ(f.theta, 0.5);
  f = std::get<CameraFix>(good("camera,1,2,3,,0.01,0.02").row);
  EXPECT_FALSE(f.theta);
  ASSERT_TRUE(f.sigma);
  EXPECT_EQ(f.sigma->y(), 0.02);
}

TEST(StreamLines, BlankAndCommentLinesAreSkipped) {
  EXPECT_TRUE(std::holds_alternative<std::monostate>(parse_stream_line("")));
  EXPECT_TRUE(std::holds_alternative<std::monostate>(parse_stream_line("  \r")));
  EXPECT_TRUE(std::holds_alternative<std::monostate>(parse_stream_line("# wheels,1,2,3,4")));
}

TEST(StreamLines, EveryBadLineHasItsKind) {
  EXPECT_EQ(bad("gyro,1,0.5"), E::kUnknownStream);
  EXPECT_EQ(bad("Wheels,1,2,3,4"), E::kUnknownStream);
  EXPECT_EQ(bad("wheels"), E::kFieldCount);
  EXPECT_EQ(bad("wheels,1,2,3"), E::kFieldCount);
  EXPECT_EQ(bad("wheels,1,2,3,4,5"), E::kFieldCount);
  EXPECT_EQ(bad("camera,1,2"), E::kFieldCount);
  EXPECT_EQ(bad("camera,1,2,3,4,5"), E::kFieldCount);  // sx without sy
  EXPECT_EQ(bad("wheels,x,2,3,4"), E::kNotANumber);
  EXPECT_EQ(bad("wheels,1,,3,4"), E::kNotANumber);
  EXPECT_EQ(bad("wheels,1,2,3,nan"), E::kNotANumber);
  EXPECT_EQ(bad("wheels,1,2,3,inf"), E::kNotANumber);
  EXPECT_EQ(bad("wheels,1,2,3,4x"), E::kNotANumber);
  EXPECT_EQ(bad("camera,1,2,3,,0,0.1"), E::kNotANumber);  // sx must be positive
  EXPECT_EQ(bad("camera,1,2,3,,0.1,"), E::kNotANumber);
  EXPECT_EQ(bad("wheels,1,2,3," + std::string(kMaxStreamLine, '4')), E::kTooLong);
}

TEST(StreamLines, AnImuLineIsTheRateOfImuCsv) {
  const StreamRow r = good("imu,2.5,-0.75");
  EXPECT_TRUE(r.stamped);
  const auto& g = std::get<ImuRow>(r.row);
  EXPECT_EQ(g.t, 2.5);
  EXPECT_EQ(g.gz, -0.75);
  EXPECT_FALSE(good("imu,,0.5").stamped);
  EXPECT_EQ(bad("imu,1"), E::kFieldCount);
  EXPECT_EQ(bad("imu,1,0.5,0"), E::kFieldCount);
  EXPECT_EQ(bad("imu,1,fast"), E::kNotANumber);
}

TEST(StreamLines, AJsonLineIsTheCsvLineByName) {
  StreamRow r = good(R"({"stream": "wheels", "t": 12.5, "vx": 0.25, "vy": -0.125, "omega": 1.5})");
  EXPECT_TRUE(r.stamped);
  const auto& w = std::get<WheelRow>(r.row);
  EXPECT_EQ(w.t, 12.5);
  EXPECT_EQ(w.twist.v.x(), 0.25);
  EXPECT_EQ(w.twist.v.y(), -0.125);
  EXPECT_EQ(w.twist.omega, 1.5);
  // Keys in any order; t absent or null: stamped at arrival.
  r = good(R"({"omega":3,"vy":2,"vx":1,"stream":"wheels"})");
  EXPECT_FALSE(r.stamped);
  EXPECT_EQ(std::get<WheelRow>(r.row).twist.omega, 3.0);
  EXPECT_FALSE(good(R"({"stream":"imu","t":null,"gz":0.5})").stamped);
  EXPECT_EQ(std::get<ImuRow>(good(R"({"stream":"imu","t":1,"gz":0.5})").row).gz, 0.5);
  CameraFix f = std::get<CameraFix>(good(R"({"stream":"camera","t":1,"x":2,"y":3})").row);
  EXPECT_EQ(f.position.y(), 3.0);
  EXPECT_FALSE(f.theta);
  EXPECT_FALSE(f.sigma);
  f = std::get<CameraFix>(good(R"({"stream":"camera","t":1,"x":2,"y":3,"theta":0.5})").row);
  EXPECT_EQ(f.theta, 0.5);
  EXPECT_FALSE(f.sigma);
  f = std::get<CameraFix>(good(R"({"stream":"camera","t":1,"x":2,"y":3,"sx":0.01,"sy":0.02})").row);
  EXPECT_FALSE(f.theta);
  ASSERT_TRUE(f.sigma);
  EXPECT_EQ(f.sigma->x(), 0.01);
  EXPECT_EQ(f.sigma->y(), 0.02);
}

TEST(StreamLines, EveryBadJsonLineHasItsKind) {
  EXPECT_EQ(bad(R"({"stream":"gyro","t":1,"gz":0.5})"), E::kUnknownStream);
  EXPECT_EQ(bad(R"({"t":1,"gz":0.5})"), E::kBadJson);                        // no stream
  EXPECT_EQ(bad(R"({"stream":"imu","t":1,"gz":0.5,"gx":0})"), E::kBadJson);  // unknown key
  EXPECT_EQ(bad(R"({"stream":"imu","t":1,"t":2,"gz":0.5})"), E::kBadJson);   // twice
  EXPECT_EQ(bad(R"({"stream":"imu","t":1,"gz":{"v":0.5}})"), E::kBadJson);   // nested
  EXPECT_EQ(bad(R"({"stream":"imu","t":1,"gz":"0.5"})"), E::kBadJson);       // a string
  EXPECT_EQ(bad(R"({"stream":"imu","t":1,"gz":0.5)"), E::kBadJson);          // unclosed
  EXPECT_EQ(bad(R"({"stream":"imu","t":1,"gz":0.5} x)"), E::kBadJson);       // trailing
  EXPECT_EQ(bad(R"({"stream":"i\"mu","gz":0.5})"), E::kBadJson);             // an escape
  EXPECT_EQ(bad("{}"), E::kBadJson);
  EXPECT_EQ(bad(R"({"stream":"imu","t":1})"), E::kNotANumber);  // gz missing
  EXPECT_EQ(bad(R"({"stream":"imu","t":1,"gz":nan})"), E::kNotANumber);
  EXPECT_EQ(bad(R"({"stream":"camera","t":1,"x":2,"y":3,"sx":0.1})"), E::kNotANumber);
}

// Sends `text` as one datagram to 127.0.0.1:port.
void send_datagram(int port, std::string_view text) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  ::sendto(fd, text.data(), text.size(), 0, reinterpret_cast<const sockaddr*>(&a), sizeof a);
  ::close(fd);
}

std::vector<StreamRow> take_until(StreamLineReader& reader, std::size_t rows, std::size_t bad) {
  std::vector<StreamRow> out;
  for (int k = 0; k < 400 && (out.size() < rows || reader.stats().bad_total() < bad); ++k) {
    reader.take(out);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return out;
}

TEST(StreamLines, UdpDatagramsCarryOneLineOrSeveral) {
  const int port = test::free_port(true);
  StreamLineReader reader("udp:" + std::to_string(port));  // 127.0.0.1 by default
  send_datagram(port, "wheels,1,0.5,0,0.25");              // one line, no newline
  send_datagram(port, "imu,1.5,0.125\n{\"stream\":\"camera\",\"t\":2,\"x\":1,\"y\":2}\n");
  send_datagram(port, "wheels,2,bad,0,0");
  const auto rows = take_until(reader, 3, 1);
  reader.stop();
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(std::get<WheelRow>(rows[0].row).twist.omega, 0.25);
  EXPECT_EQ(std::get<ImuRow>(rows[1].row).gz, 0.125);
  EXPECT_EQ(std::get<CameraFix>(rows[2].row).position.y(), 2.0);
  const auto stats = reader.stats();
  EXPECT_EQ(stats.wheels, 1u);
  EXPECT_EQ(stats.imu, 1u);
  EXPECT_EQ(stats.fixes, 1u);
  EXPECT_EQ(stats.bad[static_cast<std::size_t>(E::kNotANumber)], 1u);
}

TEST(StreamLines, OnTheMonotonicClockTIsTheArrivalToMap) {
  const int port = test::free_port(true);
  StreamLineReader reader("udp:127.0.0.1:" + std::to_string(port), StreamClock::kMonotonic);
  send_datagram(port, "imu,1234.5,0.5\nimu,1234.25,0.5\n");  // the second goes back in time
  const auto rows = take_until(reader, 1, 1);
  reader.stop();
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_FALSE(rows[0].stamped) << "its t is mapped onto the source's clock by the run";
  EXPECT_EQ(std::chrono::duration<double>(rows[0].arrival.time_since_epoch()).count(), 1234.5);
  EXPECT_EQ(reader.stats().bad[static_cast<std::size_t>(E::kTimeBackwards)], 1u);
}

TEST(StreamLines, AUdpAddressThatCannotBeUsedIsRefused) {
  EXPECT_THROW(StreamLineReader("udp:127.0.0.1:70000"), Error);
  EXPECT_THROW(StreamLineReader("udp:no-such-host.invalid:9000"), Error);
  const int port = test::free_port(true);
  StreamLineReader first("udp:" + std::to_string(port));
  EXPECT_THROW(StreamLineReader("udp:" + std::to_string(port)), Error);  // in use
}

TEST(StreamLines, TheReaderCountsBadLinesAndSaysEachKindOnceWithItsLine) {
  const fs::path dir = test::scratch_dir("stream_lines_reader");
  const fs::path file = dir / "streams.csv";
  std::ofstream(file) << "wheels,1,0,0,0\nwheels,0.5,0,0,0\ngyro,1\ngyro,2\ncamera,2,1,1\n"
                         "wheels,,1,1,1\nwheels,2,0,0";  // the last without its newline
  StreamLineReader reader(file.string());
  std::vector<StreamRow> rows;
  for (int k = 0; k < 200 && (rows.size() < 3 || reader.stats().bad_total() < 4); ++k) {
    reader.take(rows);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  reader.stop();
  reader.take(rows);
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_TRUE(std::holds_alternative<WheelRow>(rows[0].row));
  EXPECT_TRUE(std::holds_alternative<CameraFix>(rows[1].row));
  EXPECT_FALSE(rows[2].stamped);
  const auto stats = reader.stats();
  EXPECT_EQ(stats.wheels, 2u);
  EXPECT_EQ(stats.fixes, 1u);
  EXPECT_EQ(stats.bad_total(), 4u);
  EXPECT_EQ(stats.bad[static_cast<std::size_t>(E::kUnknownStream)], 2u);
  std::vector<std::pair<E, std::string>> said;
  while (auto e = reader.take_new_error()) said.push_back(*e);
  EXPECT_EQ(said,
            (std::vector<std::pair<E, std::string>>{{E::kUnknownStream, "gyro,1"},
                                                    {E::kFieldCount, "wheels,2,0,0"},
                                                    {E::kTimeBackwards, "wheels,0.5,0,0,0"}}));
}

TEST(StreamLines, ABadLineIsShownShortAndPrintable) {
  const fs::path dir = test::scratch_dir("stream_lines_shown");
  const fs::path file = dir / "streams.csv";
  std::ofstream(file) << "wheels,1,2,3," << std::string(3000, '4') << "\ngyro\x01,1\n";
  StreamLineReader reader(file.string());
  for (int k = 0; k < 200 && reader.stats().bad_total() < 2; ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  reader.stop();
  std::vector<std::pair<E, std::string>> said;
  while (auto e = reader.take_new_error()) said.push_back(*e);
  ASSERT_EQ(said.size(), 2u);
  EXPECT_EQ(said[0], (std::pair<E, std::string>{E::kUnknownStream, "gyro\\x01,1"}));
  EXPECT_EQ(said[1].first, E::kTooLong);
  EXPECT_EQ(said[1].second, "wheels,1,2,3," + std::string(200 - 13, '4'));
}

TEST(StreamLines, ATimeBeyondTheLogsBoundIsBad) {
  EXPECT_EQ(bad("wheels,1e300,0,0,0"), E::kTimeOutOfRange);
  EXPECT_EQ(bad("imu,-4.000001e9,0"), E::kTimeOutOfRange);
  EXPECT_EQ(bad("{\"stream\":\"camera\",\"t\":1e20,\"x\":1,\"y\":2}"), E::kTimeOutOfRange);
  EXPECT_EQ(std::get<WheelRow>(good("wheels,4e9,0,0,0").row).t, 4e9);
  EXPECT_EQ(std::get<ImuRow>(good("imu,-4e9,0").row).t, -4e9);
}

// A value beyond core/plausible.hpp's bounds is a bad line, as in the logs.
TEST(StreamLines, AnImplausibleValueIsBad) {
  EXPECT_EQ(bad("wheels,1,1.7e308,0,0"), E::kImplausible);
  EXPECT_EQ(bad("wheels,1,0,-100.5,0"), E::kImplausible);
  EXPECT_EQ(bad("wheels,,0,0,1001"), E::kImplausible);
  EXPECT_EQ(bad("imu,1,-2000"), E::kImplausible);
  EXPECT_EQ(bad("camera,1,1e300,0"), E::kImplausible);
  EXPECT_EQ(bad("camera,1,0,0,1e8"), E::kImplausible);
  EXPECT_EQ(bad("camera,1,0,0,,0.01,2e6"), E::kImplausible);
  EXPECT_EQ(bad("{\"stream\":\"imu\",\"gz\":1e300}"), E::kImplausible);
  EXPECT_EQ(std::get<WheelRow>(good("wheels,1,100,-100,1000").row).twist.omega, 1000.0);
  EXPECT_EQ(std::get<ImuRow>(good("imu,1,-1000").row).gz, -1000.0);
  EXPECT_EQ(std::get<CameraFix>(good("camera,1,1e6,-1e6,1e7,1e6,1e6").row).position.x(), 1e6);
}

// Polls `reader` until `rows` good lines were taken (30 s at most: a
// failure then, never a pass on what came).
std::vector<StreamRow> take_all(StreamLineReader& reader, std::size_t rows) {
  std::vector<StreamRow> out;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (out.size() < rows && std::chrono::steady_clock::now() < deadline) {
    reader.take(out);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return out;
}

// Against the source's clock (at 0 s, running at 1 s per s), a line 3000 s
// ahead is bad and does not become its stream's time: a later line with a
// t of the source's clock is taken, not counted as going back in time.
TEST(StreamLines, ALineFarAheadOfTheSourcesClockIsBadAndNotTheStreamsTime) {
  const fs::path dir = test::scratch_dir("stream_lines_ahead");
  const fs::path file = dir / "streams.csv";
  std::ofstream(file) << "wheels,3000,0,0,0\nwheels,1,0,0,0\nwheels,59,0,0,0\nimu,61000,0\n"
                         "imu,2,0.5\n";
  StreamLineReader reader(file.string(), StreamClock::kSource,
                          SourceClock{0.0, std::chrono::steady_clock::now(), 1.0});
  const auto rows = take_all(reader, 3);
  reader.stop();
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(std::get<WheelRow>(rows[0].row).t, 1.0);
  EXPECT_EQ(std::get<WheelRow>(rows[1].row).t, 59.0);
  EXPECT_EQ(std::get<ImuRow>(rows[2].row).t, 2.0);
  const auto stats = reader.stats();
  EXPECT_EQ(stats.bad[static_cast<std::size_t>(E::kTimeAhead)], 2u);
  EXPECT_EQ(stats.bad[static_cast<std::size_t>(E::kTimeBackwards)], 0u);
  EXPECT_EQ(stats.first[static_cast<std::size_t>(E::kTimeAhead)], "wheels,3000,0,0,0");
}

// On the monotonic clock, a t more than 60 s after this machine's now (at
// --speed 1) is ahead alike.
TEST(StreamLines, OnTheMonotonicClockALineFarAheadOfNowIsBad) {
  const double now =
      std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
  const fs::path dir = test::scratch_dir("stream_lines_ahead_monotonic");
  const fs::path file = dir / "streams.csv";
  std::ofstream(file) << fmt::format("imu,{},0\nimu,{},0.5\n", now + 3000.0, now + 1.0);
  StreamLineReader reader(file.string(), StreamClock::kMonotonic,
                          SourceClock{0.0, std::chrono::steady_clock::now(), 1.0});
  const auto rows = take_all(reader, 1);
  reader.stop();
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(std::get<ImuRow>(rows[0].row).gz, 0.5);
  EXPECT_EQ(reader.stats().bad[static_cast<std::size_t>(E::kTimeAhead)], 1u);
}

// At most kMaxQueuedLines good lines wait for the run: from a FIFO the
// lines beyond are dropped and counted (the writer is never held up); a
// file is read as the run takes its lines, and none is dropped.
TEST(StreamLines, LinesBeyondTheQueuesBoundAreDroppedFromAFifoAndWaitInAFile) {
  const std::size_t n = kMaxQueuedLines + 4464;
  std::string text;
  for (std::size_t k = 0; k < n; ++k) text += "wheels,,0.1,0,0\n";
  const fs::path dir = test::scratch_dir("stream_lines_bound");
  const fs::path fifo = dir / "fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  {
    StreamLineReader reader(fifo.string());
    std::thread writer([&] { std::ofstream(fifo) << text; });
    writer.join();
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (reader.stats().wheels < n && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    const auto stats = reader.stats();
    ASSERT_EQ(stats.wheels, n);
    EXPECT_EQ(stats.overflow, n - kMaxQueuedLines);
    std::vector<StreamRow> rows;
    reader.take(rows);
    EXPECT_EQ(rows.size(), kMaxQueuedLines);
  }
  const fs::path file = dir / "streams.csv";
  std::ofstream(file) << text;
  StreamLineReader reader(file.string());
  const auto rows = take_all(reader, n);
  EXPECT_EQ(rows.size(), n);
  EXPECT_EQ(reader.stats().overflow, 0u);
}

// An input without line ends (/dev/zero) is no stream of lines: its first
// line is counted too long as soon as it passes the bound, and after a
// megabyte without a line end it is read no further (issue #47, item 10:
// it burnt a core and reported 0 bad lines).
TEST(StreamLines, AnInputWithoutLineEndsIsCountedAndNotReadForever) {
  StreamLineReader reader("/dev/zero");
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (!reader.stats().not_lines && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  const auto stats = reader.stats();
  EXPECT_TRUE(stats.not_lines);
  EXPECT_EQ(stats.bad[static_cast<std::size_t>(E::kTooLong)], 1u);
  EXPECT_EQ(stats.bad_total(), 1u);
  std::string shown;  // the first 200 bytes, escaped
  for (int k = 0; k < 200; ++k) shown += "\\x00";
  EXPECT_EQ(stats.first[static_cast<std::size_t>(E::kTooLong)], shown);
}

TEST(StreamLines, AMissingFileIsRefusedByName) {
  EXPECT_THROW(StreamLineReader("/nonexistent/streams"), IoError);
}

// A live run over a log's mice with the wheel rows arriving as stream lines
// (each with its t), recorded with StreamCsvWriter: the recording replays to
// the live run's steps, and those are the log's own replay's.
TEST(StreamLines, ALiveRunWithWheelLinesReplaysToTheSameSteps) {
  const SensorArray array = test::skewed_array();
  const fs::path dir = test::scratch_dir("stream_lines_live");
  const std::vector<std::string> names{"a", "b", "c", "d"};
  test::write_log(test::synthesise(array, test::mixed_motion, 3.0, 0.002), array, names, dir);
  const RobotConfig config = read_config(dir / "robot.yaml");
  // Wheels at 50 Hz reading 5 % slow: lines with t, all written before the run.
  const fs::path lines = dir / "streams.csv";
  {
    std::ofstream out(lines);
    for (int k = 1; k <= 150; ++k) {
      const double t = 0.02 * k;
      const Twist2 x = test::mixed_motion(t - 0.01);
      out << fmt::format("wheels,{},{},{},{}\n", t, 0.95 * x.v.x(), 0.95 * x.v.y(), 0.95 * x.omega);
    }
  }
  OdometryOptions options;
  options.estimator = EstimatorKind::kConsensus;
  options.rate = 100.0;
  struct Step {
    double t;
    Pose2 pose;
  };
  const auto collect = [](std::vector<Step>& into) {
    return [&into](const OdometryStep& step) { into.push_back({step.t(), step.pose}); };
  };

  std::vector<Step> live;
  const fs::path recorded = dir / "recorded";
  fs::create_directories(recorded);
  {
    MiceReader mice(dir / "mice.csv", config);
    StreamLineReader streams(lines.string());
    // All lines read before the run starts.
    for (int k = 0; k < 200 && streams.stats().wheels < 150; ++k) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    ASSERT_EQ(streams.stats().wheels, 150u);
    LiveRunSource source(mice, 4, "live");
    source.add_streams(streams, 1.0);
    StreamCsvWriter writer(recorded, "test");
    RunCallbacks callbacks;
    callbacks.on_step = collect(live);
    callbacks.on_row = [&](const InputRow& row) {
      if (const auto* w = std::get_if<WheelRow>(&row)) writer.write(*w);
    };
    const OdometryRun run = run_loop(config, "robot.yaml", options, source, "live", callbacks);
    EXPECT_EQ(run.wheel_rows, 150u);
    writer.commit();
  }
  fs::copy_file(dir / "mice.csv", recorded / "mice.csv");
  std::vector<Step> replayed;
  run_odometry(config, "robot.yaml", resolve_log(recorded), options, collect(replayed));
  ASSERT_EQ(live.size(), replayed.size());
  ASSERT_GT(live.size(), 250u);
  for (std::size_t k = 0; k < live.size(); ++k) {
    ASSERT_EQ(live[k].t, replayed[k].t) << k;
    ASSERT_EQ(live[k].pose.t, replayed[k].pose.t) << k;
    ASSERT_EQ(live[k].pose.theta, replayed[k].pose.theta) << k;
  }
  // The recording is the lines' rows: 150 of them, the same numbers.
  WheelsReader wheels(recorded / "wheels.csv");
  std::size_t n = 0;
  while (const auto w = wheels.next()) {
    ++n;
    const Twist2 x = test::mixed_motion(0.02 * static_cast<double>(n) - 0.01);
    EXPECT_EQ(w->t, 0.02 * static_cast<double>(n)) << n;
    EXPECT_EQ(w->twist.omega, 0.95 * x.omega) << n;
  }
  EXPECT_EQ(n, 150u);
}

}  // namespace
}  // namespace moa::io
