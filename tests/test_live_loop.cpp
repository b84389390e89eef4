// moa in a robot's loop (issue #31), end to end: moa live replays a 1 kHz
// log of four sensors in real time while another process (this test's
// sender thread) sends wheel twists (CSV) and gyro rates (JSON) over UDP,
// stamped on this machine's monotonic clock, and a third (the reader
// thread) reads the pose stream from moa's standard output and stops
// reading after the first second. moa must finish, count the lines it could
// not hand over, and the lines it did must be the steps that `moa odometry`
// computes from the run's recording: the stalled reader cost the estimator
// nothing, and every stream row moa took was recorded.
#include <arpa/inet.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "moa/formats/config.hpp"
#include "support/http.hpp"
#include "support/json_value.hpp"
#include "support/run.hpp"
#include "support/slow.hpp"
#include "support/synth.hpp"

extern char** environ;

namespace moa::test {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

constexpr double kDuration = 3.0;  // s of log
constexpr double kPeriod = 1e-3;   // s: rows, epochs, wheel and gyro lines at 1 kHz

// A port of the loopback free a moment ago.

// The rows of a CSV file as fields (comments and header skipped).
std::vector<std::vector<std::string>> csv_rows(const fs::path& file) {
  std::istringstream in(read_text(file));
  std::vector<std::vector<std::string>> rows;
  bool header = true;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    if (header) {
      header = false;
      continue;
    }
    std::vector<std::string> fields;
    std::istringstream f(line);
    for (std::string field; std::getline(f, field, ',');) fields.push_back(field);
    rows.push_back(fields);
  }
  return rows;
}

TEST(LiveLoop, PosesOverAStalledReaderAreTheRecordingsReplayAndDropsAreCounted) {
  // Real time: moa must keep up with a 1 kHz replay against a sender of
  // wheel and gyro rows on the wall clock. Built for AddressSanitizer it
  // does not, and the streams then lead the mice rows past their bound (a
  // refusal, as designed: "wheel rows fed too far ahead"). The Release pass
  // runs it.
  MOA_SKIP_UNDER_SANITIZER("a 1 kHz replay against a real-time sender");
  const fs::path dir = scratch_dir("live_loop");
  const SensorArray array = skewed_array();
  const std::vector<std::string> names{"m1", "m2", "m3", "m4"};
  write_log(synthesise(array, mixed_motion, kDuration, kPeriod), array, names, dir / "log");
  const fs::path record = dir / "rec";
  const int port = test::free_port(true);

  // moa, its standard output a pipe to the reader.
  int out[2];
  ASSERT_EQ(::pipe(out), 0);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, out[1], 1);
  posix_spawn_file_actions_addclose(&actions, out[0]);
  const std::string err_file = (dir / "stderr").string();
  posix_spawn_file_actions_addopen(&actions, 2, err_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                   0644);
  std::vector<std::string> args{MOA_CLI_PATH,      "live",
                                "--config",        (dir / "log" / "robot.yaml").string(),
                                "--replay",        (dir / "log").string(),
                                "--streams",       "udp:" + std::to_string(port),
                                "--streams-clock", "monotonic",
                                "--pose-out",      "-",
                                "--record",        record.string(),
                                "--estimator",     "consensus",
                                "--rate",          "1000"};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  const auto started = std::chrono::steady_clock::now();
  ASSERT_EQ(posix_spawn(&pid, MOA_CLI_PATH, &actions, nullptr, argv.data(), environ), 0);
  posix_spawn_file_actions_destroy(&actions);
  ::close(out[1]);

  // The robot's program: a wheel and a gyro line per ms, its own clock's t.
  std::atomic<bool> done{false};
  std::thread sender([&] {
    const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    const auto t0 = std::chrono::steady_clock::now();
    for (int k = 1; !done; ++k) {
      std::this_thread::sleep_until(t0 + k * 1ms);
      const double now =
          std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
              .count();
      const Twist2 x = mixed_motion(k * kPeriod - kPeriod / 2);
      const std::string wheels = "wheels," + std::to_string(now) + "," + std::to_string(x.v.x()) +
                                 "," + std::to_string(x.v.y()) + "," + std::to_string(x.omega) +
                                 "\n" + "{\"stream\": \"imu\", \"t\": " + std::to_string(now) +
                                 ", \"gz\": " + std::to_string(x.omega) + "}\n";
      ::sendto(fd, wheels.data(), wheels.size(), 0, reinterpret_cast<const sockaddr*>(&a),
               sizeof a);
    }
    ::close(fd);
  });
  // The reader: a second of lines, then it stops reading until moa has ended.
  std::string text;
  std::thread reader([&] {
    char buffer[65536];
    const auto until = std::chrono::steady_clock::now() + 1s;
    while (std::chrono::steady_clock::now() < until) {
      const ssize_t n = ::read(out[0], buffer, sizeof buffer);
      if (n <= 0) return;
      text.append(buffer, static_cast<std::size_t>(n));
    }
    while (!done) std::this_thread::sleep_for(10ms);
    for (ssize_t n; (n = ::read(out[0], buffer, sizeof buffer)) > 0;) {
      text.append(buffer, static_cast<std::size_t>(n));
    }
  });
  int status = 0;
  // A moa that waited for its reader would never end: its reader waits for it.
  const auto deadline = started + 30s;
  while (::waitpid(pid, &status, WNOHANG) == 0 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(10ms);
  }
  const bool ended = std::chrono::steady_clock::now() < deadline;
  if (!ended) {
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &status, 0);
  }
  done = true;
  sender.join();
  reader.join();
  ::close(out[0]);
  const std::string err = read_text(dir / "stderr");
  ASSERT_TRUE(ended) << "moa live waited for its stalled reader\n" << err;
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << err;

  // The summary (on stderr: stdout is the stream) counts the lines dropped.
  std::smatch m;
  ASSERT_TRUE(std::regex_search(err, m, std::regex("pose stream: (\\d+) lines, (\\d+) dropped")))
      << err;
  const std::size_t lines = std::stoul(m[1]);
  const std::size_t dropped = std::stoul(m[2]);
  EXPECT_GT(dropped, 0u) << "the reader stopped for seconds: lines were dropped";
  ASSERT_TRUE(std::regex_search(
      err, m,
      std::regex("streams: (\\d+) wheel rows, (\\d+) gyro rows and 0 camera fixes read, (\\d+), "
                 "(\\d+) and 0 fed")))
      << err;
  const std::size_t wheels_fed = std::stoul(m[3]), gyro_fed = std::stoul(m[4]);
  // Nearly every ms of the run brought a line of each (a few arrive after the last mice row).
  EXPECT_GT(wheels_fed, static_cast<std::size_t>(0.8 * kDuration / kPeriod)) << err;
  EXPECT_GT(gyro_fed, static_cast<std::size_t>(0.8 * kDuration / kPeriod)) << err;
  EXPECT_EQ(csv_rows(record / "wheels.csv").size(), wheels_fed);
  EXPECT_EQ(csv_rows(record / "imu.csv").size(), gyro_fed);

  // The recording's replay: one row per step, the stream's lines numbered alike.
  const fs::path replay = dir / "replay.csv";
  const auto r = run_moa("odometry --config " + (record / "robot.yaml").string() + " --log " +
                         record.string() + " --estimator consensus --rate 1000 --quiet --out " +
                         replay.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto rows = csv_rows(replay);
  ASSERT_EQ(rows.size(), lines) << "a line per step";
  std::istringstream in(text);
  std::size_t got = 0;
  double previous_seq = -1;
  for (std::string line; std::getline(in, line); ++got) {
    const JsonValue j = JsonValue::parse(line);
    const double seq = j["seq"].number();
    ASSERT_GT(seq, previous_seq);
    previous_seq = seq;
    const auto& row = rows.at(static_cast<std::size_t>(seq));
    // Both written as the shortest text of the same doubles: equal.
    EXPECT_EQ(j["t"].number(), std::stod(row[0])) << line;
    EXPECT_EQ(j["x"].number(), std::stod(row[1])) << line;
    EXPECT_EQ(j["y"].number(), std::stod(row[2])) << line;
    EXPECT_EQ(j["theta"].number(), std::stod(row[3])) << line;
    EXPECT_EQ(j["vx"].number(), std::stod(row[4])) << line;
    EXPECT_EQ(j["vy"].number(), std::stod(row[5])) << line;
    EXPECT_EQ(j["omega"].number(), std::stod(row[6])) << line;
    EXPECT_EQ(j["source"].string(), row[10]) << line;
  }
  EXPECT_EQ(got + dropped, lines) << "every line delivered or counted";
  EXPECT_GT(got, 500u) << "the first second's lines were read";
}

}  // namespace
}  // namespace moa::test
