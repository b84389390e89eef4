// moa live --replay and --serve: a log played at its own pace through the
// live path, the dashboard's page and event stream over loopback HTTP, the
// page in headless Chromium while a replay runs, and the server's bounds
// (clients, a client that reads nothing).
#include <arpa/inet.h>
#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <future>
#include <map>
#include <regex>
#include <sstream>
#include <thread>

#include "moa/formats/config.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/log.hpp"
#include "moa/formats/odometry_csv.hpp"
#include "moa/sources/replay_reader.hpp"
#include "moa/web/dashboard.hpp"
#include "support/browser.hpp"
#include "support/http.hpp"
#include "support/pty_moa.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

/// A 40 s simulated log (the calibration scenario: four sensors, mixed
/// motion), made once and removed at exit.
const fs::path& simulated_log() {
  struct Log {
    fs::path dir = test::scratch_dir("live-dashboard-log");
    Log() {
      const auto r =
          test::run_moa("simulate --scenario calibration --seed 1 --out " + dir.string());
      EXPECT_EQ(r.exit_code, 0) << r.err;
    }
    ~Log() { fs::remove_all(dir); }
  };
  static const Log log;
  return log.dir;
}

/// The data lines of an event stream's default ("message") events.
std::vector<std::string> events_of(const std::string& stream) {
  std::vector<std::string> out;
  std::istringstream in(stream);
  std::string line;
  bool named = false;
  while (std::getline(in, line)) {
    if (line.empty()) {
      named = false;
    } else if (line.rfind("event:", 0) == 0) {
      named = true;
    } else if (line.rfind("data: ", 0) == 0 && !named) {
      out.push_back(line.substr(6));
    }
  }
  return out;
}

TEST(ReplayReader, GivesTheLogsRowsAtItsPaceTimesTheSpeed) {
  const fs::path& log = simulated_log();
  const io::RobotConfig config = io::read_config(log / "robot.yaml");
  io::MiceReader plain(log, config);
  int ticks = 0;
  io::LiveHooks hooks;
  hooks.tick = [&] { ++ticks; };
  io::ReplayOptions options;
  options.speed = 20.0;
  io::ReplayReader replay(log, config, options, hooks);
  ASSERT_EQ(replay.start_time(), plain.start_time());
  const auto started = Clock::now();
  double t_last = 0.0;
  std::size_t rows = 0;
  while (const auto row = replay.next()) {
    const auto expected = plain.next();
    ASSERT_TRUE(expected);
    ASSERT_EQ(row->t, expected->t);
    ASSERT_EQ(row->sensor, expected->sensor);
    ASSERT_EQ(row->counts, expected->counts);
    // Never early: row k comes no sooner than (t_k - t0) / speed after the start.
    ASSERT_GE(std::chrono::duration<double>(Clock::now() - started).count(),
              (row->t - replay.start_time()) / options.speed - 1e-3);
    t_last = row->t;
    ++rows;
  }
  EXPECT_FALSE(plain.next());
  EXPECT_EQ(replay.rows(), rows);
  const double wall = std::chrono::duration<double>(Clock::now() - started).count();
  const double span = (t_last - replay.start_time()) / options.speed;  // 2 s
  EXPECT_GE(wall, span - 1e-3);
  EXPECT_LT(wall, span + 1.0);
  EXPECT_GE(ticks, 10);  // the status hook runs while it waits (every 0.1 s)
}

TEST(ReplayReader, StopsWhenTheStopHookSaysSo) {
  const fs::path& log = simulated_log();
  const io::RobotConfig config = io::read_config(log / "robot.yaml");
  const auto started = Clock::now();
  io::LiveHooks hooks;
  hooks.stop = [&] { return Clock::now() - started > std::chrono::milliseconds(300); };
  io::ReplayReader replay(log, config, {}, hooks);
  while (replay.next()) {
  }
  EXPECT_LT(std::chrono::duration<double>(Clock::now() - started).count(), 1.0);
}

// Held (the guided wizard waiting for a key) from the 100th row for 0.5 s:
// no row comes while held, and the rows after keep the log's pace from
// there, 0.5 s later than unheld (speed 20: within 2 s of log, 0.1 s).
TEST(ReplayReader, WaitsWhileHeldWithItsClockStopped) {
  const fs::path& log = simulated_log();
  const io::RobotConfig config = io::read_config(log / "robot.yaml");
  bool hold = false;
  Clock::time_point released{};
  io::LiveHooks hooks;
  hooks.hold = [&] {
    if (hold && Clock::now() >= released) hold = false;
    return hold;
  };
  io::ReplayOptions options;
  options.speed = 20.0;
  io::ReplayReader replay(log, config, options, hooks);
  const double t0 = replay.start_time();
  const auto started = Clock::now();
  const auto since = [&] { return std::chrono::duration<double>(Clock::now() - started).count(); };
  for (int k = 0; k < 100; ++k) ASSERT_TRUE(replay.next());
  hold = true;
  released = Clock::now() + std::chrono::milliseconds(500);
  const auto row = replay.next();
  ASSERT_TRUE(row);
  EXPECT_GE(Clock::now(), released);  // nothing while held
  // Then on the log's pace, shifted by the hold: never early, and, rows
  // being 10 ms apart, not late by much.
  double t_last = row->t;
  while (const auto next = replay.next()) {
    if (next->t - t0 > 2.0) break;
    ASSERT_GE(since(), (next->t - t0) / options.speed + 0.5 - 1e-3);
    t_last = next->t;
  }
  EXPECT_LT(since(), (t_last - t0) / options.speed + 0.5 + 0.3);
}

TEST(ReplayReader, SpeedMustBePositiveAndFinite) {
  const fs::path& log = simulated_log();
  for (const char* speed : {"nan", "inf", "0", "-1"}) {
    const auto r = test::run_moa("live --config " + (log / "robot.yaml").string() + " --replay " +
                                 log.string() + " --speed " + speed + " --duration 1");
    EXPECT_NE(r.exit_code, 0) << speed;
    EXPECT_THAT(r.err, HasSubstr("--speed")) << speed;
  }
  io::ReplayOptions options;
  options.speed = std::numeric_limits<double>::quiet_NaN();
  ASSERT_TRUE(options.validate());
  EXPECT_STREQ(options.validate()->message(), "speed: must be finite, is nan");
  options.speed = -1;
  EXPECT_STREQ(options.validate()->message(), "speed: must be > 0, is -1");
  options.speed = 2;
  EXPECT_FALSE(options.validate());
}

TEST(LiveDashboard, ServesThePageAndAtLeastTwentyEventsInTwoSeconds) {
  const fs::path& log = simulated_log();
  const int port = test::free_port();
  test::BackgroundMoa moa("live --config " + (log / "robot.yaml").string() + " --replay " +
                          log.string() + " --speed 2 --serve 127.0.0.1:" + std::to_string(port) +
                          " --duration 8");
  ASSERT_TRUE(test::wait_for_server(port, 10.0)) << moa.err();

  const auto page = test::http_get(port, "/", 5.0);
  ASSERT_EQ(page.status, 200);
  EXPECT_THAT(page.headers, HasSubstr("text/html"));
  EXPECT_THAT(page.body, HasSubstr("<canvas id=\"chart-trajectory\""));
  EXPECT_THAT(page.body, HasSubstr("Chart.js v3"));  // inlined, not referenced
  EXPECT_THAT(page.body, Not(HasSubstr("http://")));
  EXPECT_THAT(page.body, Not(HasSubstr("https://")));
  EXPECT_FALSE(std::regex_search(page.body, std::regex(R"((src|href)\s*=)")))
      << "the page references something";

  const auto stream = test::http_get(port, "/events", 2.0);
  ASSERT_EQ(stream.status, 200);
  EXPECT_THAT(stream.headers, HasSubstr("text/event-stream"));
  const auto events = events_of(stream.body);
  EXPECT_GE(events.size(), 20u);
  EXPECT_LE(events.size(), 50u);  // decimated: at most ~20 events/s whatever the rate
  const std::regex number(R"(-?[0-9][0-9.e+-]*)");
  for (const auto& e : events) {
    ASSERT_EQ(e.front(), '{') << e;
    ASSERT_EQ(e.back(), '}') << e;
    for (const char* key : {"t", "x", "y", "theta"}) {
      std::smatch m;
      EXPECT_TRUE(std::regex_search(
          e, m, std::regex("\"" + std::string(key) + "\": -?[0-9][0-9.e+-]*[,}]")))
          << key << " in " << e;
    }
    EXPECT_THAT(e, HasSubstr("\"sensors\": [{\"name\": \"m1\""));
    EXPECT_THAT(e, HasSubstr("\"omega\": "));
    EXPECT_THAT(e, HasSubstr("\"squal\": "));
    EXPECT_THAT(e, HasSubstr("\"used\": "));
    EXPECT_THAT(e, HasSubstr("\"excluded\": "));
  }
  EXPECT_EQ(moa.wait(15.0), 0) << moa.err();
  EXPECT_THAT(moa.out(), HasSubstr("dashboard sent"));
}

TEST(LiveDashboard, BoundsClientsAndASlowClientNeverSlowsThePublisher) {
  const io::RobotConfig config = io::read_config(simulated_log() / "robot.yaml");
  io::DashboardOptions options;
  options.port = 0;
  options.max_clients = 2;
  options.client_queue = 4;
  options.send_buffer = 4096;
  options.max_rate = 100.0;
  io::Dashboard dashboard(config, options);
  const int port = dashboard.port();
  ASSERT_GT(port, 0);

  // Two clients that connect and never read: their sockets fill up.
  std::vector<int> sockets;
  for (int k = 0; k < 2; ++k) {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    const int small = 1024;  // a receive window that fills at once
    setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
    const std::string get = "GET /events HTTP/1.1\r\nHost: x\r\n\r\n";
    ASSERT_EQ(write(fd, get.data(), get.size()), static_cast<ssize_t>(get.size()));
    sockets.push_back(fd);
  }
  for (int i = 0; i < 200 && dashboard.stats().clients < 2; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_EQ(dashboard.stats().clients, 2u);
  EXPECT_EQ(test::http_get(port, "/events", 2.0).status, 503);
  EXPECT_EQ(test::http_get(port, "/", 2.0).status, 200);  // the page still comes

  // 4 s of epochs at 1 kHz, 400 events of ~1 kB: the publisher never waits
  // for the clients, whose queues stay bounded (the oldest events dropped).
  ArraySample sample;
  sample.size = config.array.size();
  sample.dt = 1e-3;
  OdometryStep step;
  step.sample = &sample;
  double worst = 0.0;
  for (int k = 0; k < 4000; ++k) {
    sample.t = k * 1e-3;
    for (int i = 0; i < sample.size; ++i) {
      sample.counts[static_cast<std::size_t>(i)] = Eigen::Vector2d(k / 3.0, -k / 7.0);
    }
    step.pose.t = Eigen::Vector2d(k * 1e-4, 0.0);
    const auto before = Clock::now();
    dashboard.publish(step);
    worst = std::max(worst, std::chrono::duration<double>(Clock::now() - before).count());
    std::this_thread::sleep_until(before + std::chrono::microseconds(1000));
  }
  const auto stats = dashboard.stats();
  EXPECT_GT(stats.events, 200u);
  EXPECT_GT(stats.dropped, 0u) << stats.events << " events, clients " << stats.clients;
  EXPECT_LT(worst, 0.05) << "publish() waited for a client";
  for (const int fd : sockets) close(fd);
}

// Ten loopback connections that send one header line a second (slow-loris)
// never keep the page from being served: each is dropped at its first pause
// longer than the request read timeout, and workers remain for the page.
TEST(LiveDashboard, SlowLorisConnectionsDoNotBlockThePage) {
  const io::RobotConfig config = io::read_config(simulated_log() / "robot.yaml");
  io::DashboardOptions options;
  options.port = 0;
  io::Dashboard dashboard(config, options);
  const int port = dashboard.port();
  ASSERT_GT(port, 0);
  std::vector<int> sockets;
  for (int k = 0; k < 10; ++k) {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
    const std::string start = "GET / HTTP/1.1\r\n";
    ASSERT_EQ(write(fd, start.data(), start.size()), static_cast<ssize_t>(start.size()));
    sockets.push_back(fd);
  }
  // Four seconds of one header line a second on every connection; the page
  // is asked for in between and must come each time.
  int served = 0;
  for (int second = 0; second < 4; ++second) {
    const auto next = Clock::now() + std::chrono::seconds(1);
    for (const int fd : sockets) {
      const std::string line = fmt::format("X-Slow-{}: a\r\n", second);
      (void)send(fd, line.data(), line.size(), MSG_NOSIGNAL);
    }
    if (test::http_get(port, "/", 0.9).status == 200) ++served;
    std::this_thread::sleep_until(next);
  }
  for (const int fd : sockets) close(fd);
  EXPECT_EQ(served, 4);
}

// A loopback connection to the dashboard.
int connect_to(int port) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}

// Sends `head`, then `filler` again and again until the server closes the
// connection or `limit` bytes were sent in all; the bytes sent. A send that
// waits 10 s (the server neither reads nor closes) ends it too.
std::size_t send_until_closed(int fd, const std::string& head, const std::string& filler,
                              std::size_t limit) {
  const timeval wait{10, 0};
  setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &wait, sizeof wait);
  std::size_t sent = 0;
  const auto send_all = [&](const std::string& bytes) {
    for (std::size_t at = 0; at < bytes.size();) {
      const ssize_t n = send(fd, bytes.data() + at, bytes.size() - at, MSG_NOSIGNAL);
      if (n <= 0) return false;
      at += static_cast<std::size_t>(n);
      sent += static_cast<std::size_t>(n);
    }
    return true;
  };
  if (!send_all(head)) return sent;
  while (sent < limit && send_all(filler)) {
  }
  return sent;
}

// True when the server has closed `fd` (end of stream or reset) within 10 s;
// what it sent before is appended to `answer`.
bool closed_by_server(int fd, std::string& answer) {
  const auto deadline = Clock::now() + std::chrono::seconds(10);
  char buffer[4096];
  while (Clock::now() < deadline) {
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, 100) <= 0) continue;
    const ssize_t n = recv(fd, buffer, sizeof buffer, 0);
    if (n <= 0) return true;
    answer.append(buffer, static_cast<std::size_t>(n));
  }
  return false;
}

// The dashboard serves GETs, and every request is bounded (issue #47, item
// 1: Debian's cpp-httplib 0.11 read a POST's 100 GB Content-Length, a
// chunked POST and endless header lines into memory until moa aborted). A
// real client over a socket sends each for up to 64 MiB: the server closes
// the connection long before (it reads at most 16 KiB of a request), a
// request other than a GET is answered 405, and the page still comes.
TEST(LiveDashboard, EveryRequestIsBoundedAndOnlyGetsAreServed) {
  const io::RobotConfig config = io::read_config(simulated_log() / "robot.yaml");
  io::DashboardOptions options;
  options.port = 0;
  io::Dashboard dashboard(config, options);
  const int port = dashboard.port();
  ASSERT_GT(port, 0);
  constexpr std::size_t kLimit = std::size_t{64} << 20;
  const std::string mib(std::size_t{1} << 20, 'x');
  struct Case {
    const char* what;
    std::string head, filler;
  };
  const std::vector<Case> cases{
      {"a POST of 100 GB", "POST / HTTP/1.1\r\nHost: x\r\nContent-Length: 100000000000\r\n\r\n",
       mib},
      {"a chunked POST to /events",
       "POST /events HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n",
       "100000\r\n" + mib + "\r\n"},
      {"a GET of endless 8 KB header lines", "GET / HTTP/1.1\r\nHost: x\r\n",
       "X-Pad: " + std::string(8000, 'y') + "\r\n"},
      {"a GET with an endless request line", "GET /", std::string(8192, 'z')},
      {"a GET with a chunked body",
       "GET / HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n",
       "100000\r\n" + mib + "\r\n"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    const int fd = connect_to(port);
    ASSERT_GE(fd, 0);
    const std::size_t sent = send_until_closed(fd, c.head, c.filler, kLimit);
    EXPECT_LT(sent, kLimit) << "the server read it all";
    std::string answer;
    EXPECT_TRUE(closed_by_server(fd, answer)) << "the connection stayed open";
    close(fd);
    EXPECT_EQ(test::http_get(port, "/", 10.0).status, 200) << "the page after it";
  }
  // Without a body, the answer comes whole: 405, the methods allowed, closed.
  for (const std::string method : {"POST", "PUT", "DELETE", "OPTIONS"}) {
    SCOPED_TRACE(method);
    const int fd = connect_to(port);
    ASSERT_GE(fd, 0);
    const std::string request = method + " /events HTTP/1.1\r\nHost: x\r\n\r\n";
    ASSERT_EQ(send(fd, request.data(), request.size(), MSG_NOSIGNAL),
              static_cast<ssize_t>(request.size()));
    std::string answer;
    EXPECT_TRUE(closed_by_server(fd, answer));
    close(fd);
    EXPECT_THAT(answer, testing::StartsWith("HTTP/1.1 405 "));
    EXPECT_THAT(answer, HasSubstr("Allow: GET, HEAD\r\n"));
    EXPECT_THAT(answer, HasSubstr("the dashboard serves GET requests only"));
  }
  // GETs as a browser sends them, several on one connection, still served.
  const int fd = connect_to(port);
  ASSERT_GE(fd, 0);
  const std::string two =
      "GET /status HTTP/1.1\r\nHost: x\r\n\r\nGET / HTTP/1.1\r\nHost: x\r\n"
      "Connection: close\r\n\r\n";
  ASSERT_EQ(send(fd, two.data(), two.size(), MSG_NOSIGNAL), static_cast<ssize_t>(two.size()));
  std::string answer;
  EXPECT_TRUE(closed_by_server(fd, answer));
  close(fd);
  EXPECT_THAT(answer, testing::StartsWith("HTTP/1.1 200 "));
  EXPECT_THAT(answer, HasSubstr("\"events\""));
  EXPECT_THAT(answer, HasSubstr("<html"));
}

TEST(LiveDashboard, ListenAddressIsHostColonPortOrAPort) {
  io::DashboardOptions o;
  io::parse_listen_address("8081", "--serve", o);
  EXPECT_EQ(o.host, "127.0.0.1");
  EXPECT_EQ(o.port, 8081);
  io::parse_listen_address("0.0.0.0:9000", "--serve", o);
  EXPECT_EQ(o.host, "0.0.0.0");
  EXPECT_EQ(o.port, 9000);
  io::parse_listen_address("[::1]:9001", "--serve", o);
  EXPECT_EQ(o.host, "::1");
  EXPECT_EQ(o.port, 9001);
  for (const char* bad : {"", "http", "70000", "-1", ":80", "host:", "1.2.3.4:8o"}) {
    try {
      io::parse_listen_address(bad, "--serve", o);
      ADD_FAILURE() << bad;
    } catch (const io::Error& e) {
      EXPECT_THAT(e.what(), HasSubstr("--serve " + std::string(bad) + ":")) << bad;
    }
  }
  const fs::path& log = simulated_log();
  const auto r = test::run_moa("live --config " + (log / "robot.yaml").string() + " --replay " +
                               log.string() + " --serve nowhere --duration 1");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("--serve nowhere: the port must be a number"));
  io::DashboardOptions invalid;
  invalid.max_rate = std::numeric_limits<double>::quiet_NaN();
  ASSERT_TRUE(invalid.validate());
  EXPECT_STREQ(invalid.validate()->message(), "max_rate: must be finite, is nan");
  const auto message = [](auto change) {
    io::DashboardOptions changed;
    change(changed);
    const auto e = changed.validate();
    return e ? std::string(e->message()) : std::string();
  };
  EXPECT_EQ(message([](auto&) {}), "");
  EXPECT_EQ(message([](auto& d) { d.host.clear(); }), "host: must not be empty");
  EXPECT_EQ(message([](auto& d) { d.port = 65536; }), "port: must be in [0, 65535], is 65536");
  EXPECT_EQ(message([](auto& d) { d.max_clients = 0; }), "max_clients: must be in [1, 64], is 0");
  EXPECT_EQ(message([](auto& d) { d.client_queue = 5000; }),
            "client_queue: must be in [1, 4096], is 5000");
  EXPECT_EQ(message([](auto& d) { d.max_rate = 0; }), "max_rate: must be > 0, is 0");
  EXPECT_EQ(message([](auto& d) { d.max_rate = 101; }), "max_rate: must be <= 100, is 101");
  EXPECT_EQ(message([](auto& d) { d.send_buffer = 1023; }),
            "send_buffer: must be in [1024, 16777216], is 1023");
  EXPECT_EQ(message([](auto& d) { d.history_points = 2000000; }),
            "history_points: must be <= 1000000, is 2000000");
  EXPECT_EQ(message([](auto& d) { d.max_warnings = 20000; }),
            "max_warnings: must be <= 10000, is 20000");
}

/// simulated_log() with one row of 32767 counts (far beyond any rated
/// speed): `moa live` skips it with a warning. Made once, removed at exit.
const fs::path& saturated_log() {
  struct Log {
    fs::path dir = test::scratch_dir("live-dashboard-saturated");
    Log() {
      const fs::path& simulated = simulated_log();
      fs::copy_file(simulated / "robot.yaml", dir / "robot.yaml");
      std::ifstream in(simulated / "mice.csv");
      std::ofstream out(dir / "mice.csv");
      std::string line;
      for (int k = 0; std::getline(in, line); ++k) {
        if (k == 400) {  // dx
          const auto a = line.find(',', line.find(',') + 1);
          const auto b = line.find(',', a + 1);
          line = line.substr(0, a + 1) + "32767" + line.substr(b);
        }
        out << line << "\n";
      }
    }
    ~Log() { fs::remove_all(dir); }
  };
  static const Log log;
  return log.dir;
}

/// The numbers of an "event: history" data line: one array per point.
std::vector<std::vector<double>> history_points(const std::string& stream) {
  std::vector<std::vector<double>> points;
  const std::string head = "event: history\ndata: {\"points\": [";
  const auto at = stream.find(head);
  if (at == std::string::npos) return points;
  const std::string body =
      stream.substr(at + head.size(), stream.find('\n', at + head.size()) - (at + head.size()));
  const std::regex point(R"(\[([^\[\]]*)\])");
  for (auto it = std::sregex_iterator(body.begin(), body.end(), point);
       it != std::sregex_iterator(); ++it) {
    std::vector<double> values;
    std::istringstream in((*it)[1].str());
    std::string value;
    while (std::getline(in, value, ',')) values.push_back(std::stod(value));
    points.push_back(values);
  }
  return points;
}

// A short replay at a terminal: when it ends, the dashboard keeps serving
// until Ctrl-C. A client that joins then gets the trajectory with the
// twist (each point the odometry moa wrote at that time), the run's
// warning (a saturated row skipped), the final state and the end, at the
// last epoch's time.
TEST(LiveDashboard, ALateJoinerGetsTheHistoryTheWarningsAndTheEnd) {
  const fs::path& log = saturated_log();
  const int port = test::free_port();
  const fs::path dir = test::scratch_dir("dashboard-late-joiner");
  const fs::path out = dir / "o.csv";
  test::PtyMoa moa({"live", "--config", (log / "robot.yaml").string(), "--replay", log.string(),
                    "--speed", "20", "--serve", "127.0.0.1:" + std::to_string(port), "--out",
                    out.string()});
  const auto deadline = Clock::now() + std::chrono::seconds(30);
  ASSERT_TRUE(moa.wait_for("shows its final state until Ctrl-C", 1, deadline)) << moa.output();

  const auto stream = test::http_get(port, "/events", 2.0);
  ASSERT_EQ(stream.status, 200);
  EXPECT_THAT(stream.body, HasSubstr("event: warning\ndata: {\"text\": \""));
  EXPECT_THAT(stream.body, HasSubstr("skipped: counts imply a speed far beyond"));
  EXPECT_EQ(events_of(stream.body).size(), 1u);  // the final state

  const io::RobotConfig config = io::read_config(log / "robot.yaml");
  io::OdometryCsvReader reader(out, config, (log / "robot.yaml").string());
  std::map<double, io::OdometryRow> written;
  double t_last = 0.0;
  while (const auto row = reader.next()) {
    written[row->t] = *row;
    t_last = row->t;
  }
  const auto points = history_points(stream.body);
  // 40 s of log at 20x, at most 20 events a second: about 40.
  EXPECT_GE(points.size(), 20u);
  for (const auto& p : points) {
    ASSERT_EQ(p.size(), 6u);
    const auto row = written.find(p[0]);
    ASSERT_NE(row, written.end()) << "no epoch at t = " << p[0];
    EXPECT_EQ(p[1], row->second.pose.t.x());
    EXPECT_EQ(p[2], row->second.pose.t.y());
    EXPECT_EQ(p[3], row->second.twist.v.x());
    EXPECT_EQ(p[4], row->second.twist.v.y());
    EXPECT_EQ(p[5], row->second.twist.omega);
  }
  ASSERT_FALSE(points.empty());
  EXPECT_EQ(points.back()[0], t_last);  // the final state is the last epoch's
  EXPECT_THAT(stream.body, HasSubstr(fmt::format("event: end\ndata: {{\"t\": {}}}", t_last)));

  moa.type("\x03");  // Ctrl-C
  EXPECT_EQ(moa.exit_code(10.0), 0) << moa.output();
  if (!HasFailure()) fs::remove_all(dir);
}

unsigned long attribute(const std::string& tag, const std::string& name) {
  std::smatch m;
  if (!std::regex_search(tag, m, std::regex(name + "=\"([0-9]+)\""))) return 0;
  return std::stoul(m[1]);
}

/// GET /status's counts; `answered` false when the server did not answer.
struct DashboardStatus {
  bool answered = false;
  long events = 0, dropped = 0, greeted = 0;
  bool ended = false;
};
DashboardStatus dashboard_status(int port) {
  const auto r = test::http_get(port, "/status", 2.0);
  DashboardStatus s;
  const auto count = [&](const char* name, long& value) {
    std::smatch m;
    if (!std::regex_search(r.body, m, std::regex(std::string("\"") + name + "\": ([0-9]+)"))) {
      return false;
    }
    value = std::stol(m[1]);
    return true;
  };
  s.answered = r.status == 200 && count("events", s.events) && count("dropped", s.dropped) &&
               count("greeted", s.greeted);
  s.ended = r.body.find("\"ended\": true") != std::string::npos;
  return s;
}

// The page is loaded while a replay runs and is fed live events: the test
// waits for the events it needs, not for a guessed time. moa replays the
// whole 40 s log at half speed (80 s: Chromium's start-up under load has
// all of it); once /status shows the page's stream greeted (every later
// event is sent to it unless dropped), the test waits until 45 more events
// were made and none of them dropped, then stops the run (SIGINT), whose
// "end" event lets Chromium dump the DOM. A run that ends first, or a page
// that had to reconnect, is a failure that says so.
TEST(LiveDashboard, ChromiumDrawsTheChartsUpdatingWhileAReplayRuns) {
  const auto chromium = test::find_chromium();
  if (!chromium) GTEST_SKIP() << "no chromium on the PATH (make deps installs it)";
  const fs::path& log = saturated_log();
  const fs::path dir = test::scratch_dir("live-dashboard-browser");
  const int port = test::free_port();
  test::BackgroundMoa moa("live --config " + (log / "robot.yaml").string() + " --replay " +
                          log.string() + " --speed 0.5 --serve 127.0.0.1:" + std::to_string(port) +
                          " --quiet");
  ASSERT_TRUE(test::wait_for_server(port, 10.0)) << moa.err();
  auto loading = std::async(std::launch::async, [&] {
    return test::load_page(*chromium, "http://127.0.0.1:" + std::to_string(port) + "/", dir, 1280,
                           900, 2000, 150);
  });
  const auto deadline = Clock::now() + std::chrono::seconds(75);
  long connected_at = -1;  // events made when the page's stream was first seen greeted
  DashboardStatus now;
  while (connected_at < 0 && Clock::now() < deadline && !now.ended) {
    now = dashboard_status(port);
    if (now.answered && now.greeted >= 1) connected_at = now.events;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_GE(connected_at, 0) << "the page did not open /events while the run lasted; moa: "
                             << moa.err();
  long fed = 0;  // events made since then and not dropped
  while (fed < 45 && Clock::now() < deadline && !now.ended) {
    now = dashboard_status(port);
    if (now.answered) fed = now.events - connected_at - now.dropped;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_GE(fed, 45) << "the run made too few events for the page (ended: " << now.ended
                     << "); moa: " << moa.err();
  ASSERT_EQ(now.greeted, 1) << "the page reconnected: events between were not counted";
  moa.signal(SIGINT);
  const test::BrowserPage page = loading.get();
  ASSERT_EQ(page.failure(), "");
  const std::string& dom = page.dom;
  const std::string& console = page.console;
  EXPECT_EQ(moa.wait(15.0), 0) << moa.err();

  EXPECT_THAT(dom, HasSubstr("data-moa-status=\"ended\""));
  EXPECT_THAT(dom, HasSubstr("the run ended at t "));
  // The warnings panel lists the skipped row.
  const auto warnings = dom.find("<ul id=\"warnings\"><li>");
  ASSERT_NE(warnings, std::string::npos) << dom;
  EXPECT_THAT(dom.substr(warnings, 400), HasSubstr("skipped: counts imply a speed far beyond"));
  EXPECT_THAT(test::tag_of(dom, "moa-errors"), HasSubstr("hidden"));
  // The heading's source, drawn: no gyro in this log, so the twist's.
  EXPECT_TRUE(
      std::regex_search(dom, std::regex("id=\"heading-source\">heading: (mice|wheels|hold)</p>")))
      << dom.substr(std::min(dom.find("heading-source"), dom.size()), 200);
  EXPECT_EQ(console.find("CONSOLE"), std::string::npos) << console;
  // The page received every live event fed to it (45 at least) and redrew
  // every chart for each, with data on it.
  const std::string body = dom.substr(dom.find("<body"), 200);
  EXPECT_GE(attribute(body, "data-events"), 45u) << body;
  for (const char* id : {"chart-trajectory", "chart-health", "chart-twist"}) {
    const std::string tag = test::tag_of(dom, id);
    EXPECT_GE(attribute(tag, "data-updates"), 45u) << id << ": " << tag;
    EXPECT_GE(attribute(tag, "data-points"), 8u) << id << ": " << tag;
  }
  if (!HasFailure()) fs::remove_all(dir);
}

}  // namespace
}  // namespace moa
