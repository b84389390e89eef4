// The pose stream (`moa live --pose-out`): its line against the step it was
// made from (formats/pose_line.hpp), and its sender against readers that are
// absent, stalled or gone (runs/pose_stream.hpp).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cmath>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "moa/formats/pose_line.hpp"
#include "moa/runs/pose_stream.hpp"
#include "support/json_value.hpp"

namespace moa::io {
namespace {

using test::JsonValue;

const std::vector<std::string> kNames{"m1", "m\"2", "m3"};

// A step whose every field differs from the others, so that a field written
// in another's place shows.
struct StepFixture {
  ArraySample sample;
  OdometryStep step;
  explicit StepFixture(double t) {
    sample.t = t;
    sample.size = 3;
    step.sample = &sample;
    step.pose = Pose2{Vec2{1.0 + t, -2.0 / 3.0}, 0.1 + t};
    step.estimate.estimate.twist = Twist2{Vec2{0.3, -0.01}, 1.0 / 7.0};
    Mat3 c;
    c << 4e-6, 1e-7, 2e-7, 1e-7, 5e-6, 3e-7, 2e-7, 3e-7, 6e-5;
    step.estimate.estimate.covariance = c;
    step.estimate.estimate.used = 0b101;
    step.estimate.excluded[1] = Exclusion::kLift;
    step.estimate.source = Source::kMice;
  }
};

// Entry (r, k) of the 6x6 for the 3x3 `c` over the planar indices 0, 1, 5.
double planar_entry(const Mat3& c, int r, int k) {
  const auto index = [](int i) { return i == 0 ? 0 : i == 1 ? 1 : i == 5 ? 2 : -1; };
  return index(r) < 0 || index(k) < 0 ? 0.0 : c(index(r), index(k));
}

TEST(PoseLine, CarriesTheStepInRep103FramesWithNavMsgsCovariances) {
  StepFixture f(0.25);
  PoseLineWriter writer(kNames);
  const std::string line(writer.format(f.step, 7));
  ASSERT_EQ(line.back(), '\n');
  EXPECT_EQ(line.find('\n'), line.size() - 1) << "one line";
  const JsonValue j = JsonValue::parse(line);
  EXPECT_EQ(j["seq"].number(), 7);
  EXPECT_EQ(j["t"].number(), 0.25);
  EXPECT_EQ(j["frame_id"].string(), "odom");
  EXPECT_EQ(j["child_frame_id"].string(), "base_link");
  // Shortest round-trip text: the same doubles.
  EXPECT_EQ(j["x"].number(), f.step.pose.t.x());
  EXPECT_EQ(j["y"].number(), f.step.pose.t.y());
  EXPECT_EQ(j["theta"].number(), f.step.pose.theta);
  EXPECT_EQ(j["vx"].number(), 0.3);
  EXPECT_EQ(j["vy"].number(), -0.01);
  EXPECT_EQ(j["omega"].number(), 1.0 / 7.0);
  EXPECT_TRUE(j["pose_covariance"].is_null()) << "dead reckoning has no pose covariance";
  const std::vector<double> twist = j["twist_covariance"].numbers();
  ASSERT_EQ(twist.size(), 36u);
  for (int r = 0; r < 6; ++r) {
    for (int k = 0; k < 6; ++k) {
      EXPECT_EQ(twist[static_cast<std::size_t>(6 * r + k)],
                planar_entry(f.step.estimate.estimate.covariance, r, k))
          << r << "," << k;
    }
  }
  EXPECT_EQ(j["source"].string(), "mice");
  ASSERT_EQ(j["used"].array().size(), 2u);
  EXPECT_EQ(j["used"][0].string(), "m1");
  EXPECT_EQ(j["used"][1].string(), "m3");
  ASSERT_EQ(j["excluded"].object().size(), 1u);
  EXPECT_EQ(j["excluded"]["m\"2"].string(), "lift");
}

TEST(PoseLine, AFusedPoseCarriesTheFiltersCovariance) {
  StepFixture f(1.0);
  f.step.fused = true;
  f.step.pose_covariance << 1e-4, 2e-5, 3e-6, 2e-5, 4e-4, 5e-6, 3e-6, 5e-6, 1e-3;
  PoseLineWriter writer(kNames);
  const JsonValue j = JsonValue::parse(writer.format(f.step, 0));
  const std::vector<double> pose = j["pose_covariance"].numbers();
  ASSERT_EQ(pose.size(), 36u);
  for (int r = 0; r < 6; ++r) {
    for (int k = 0; k < 6; ++k) {
      EXPECT_EQ(pose[static_cast<std::size_t>(6 * r + k)],
                planar_entry(f.step.pose_covariance, r, k));
    }
  }
}

// Every line a stream delivered on `fd` (read until end of file).
std::vector<JsonValue> read_lines(int fd) {
  std::string text;
  char buffer[65536];
  for (ssize_t n; (n = ::read(fd, buffer, sizeof buffer)) > 0;) {
    text.append(buffer, static_cast<std::size_t>(n));
  }
  std::vector<JsonValue> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(JsonValue::parse(line));
  EXPECT_TRUE(text.empty() || text.back() == '\n') << "lines are whole";
  return lines;
}

TEST(PoseStream, AStalledReaderCostsNothingAndGetsTheLinesThatFitWholeAndRight) {
  int p[2];
  ASSERT_EQ(::pipe(p), 0);
  constexpr std::size_t kSteps = 5000;  // ~1.6 MB of lines: far beyond pipe and buffer
  PoseStream stream(p[1], kNames, 0.0);
  for (std::size_t k = 0; k < kSteps; ++k) {
    StepFixture f(static_cast<double>(k) * 1e-3);
    stream.write(f.step);  // returns with nobody reading: else the test hangs here
  }
  EXPECT_EQ(stream.stats().lines, kSteps);
  EXPECT_GT(stream.stats().dropped, 0u);
  // The reader comes back: the buffered lines are delivered, the rest dropped.
  std::vector<JsonValue> got;
  std::thread reader([&] { got = read_lines(p[0]); });
  stream.finish(std::chrono::milliseconds(5000));
  ::close(p[1]);
  reader.join();
  ::close(p[0]);
  EXPECT_EQ(got.size() + stream.stats().dropped, kSteps);
  // Lines dropped when full: the delivered ones are the first, each that step's.
  for (std::size_t k = 0; k < got.size(); ++k) {
    ASSERT_EQ(got[k]["seq"].number(), static_cast<double>(k));
    StepFixture f(static_cast<double>(k) * 1e-3);
    EXPECT_EQ(got[k]["x"].number(), f.step.pose.t.x());
    EXPECT_EQ(got[k]["theta"].number(), f.step.pose.theta);
  }
}

TEST(PoseStream, AReaderGoneMidRunIsCountedAndDoesNotEndTheProcess) {
  int p[2];
  ASSERT_EQ(::pipe(p), 0);
  PoseStream stream(p[1], kNames, 0.0);
  StepFixture f(0.0);
  stream.write(f.step);
  ::close(p[0]);  // the reader is gone: EPIPE (SIGPIPE would end the test)
  for (int k = 0; k < 10; ++k) stream.write(f.step);
  stream.finish(std::chrono::milliseconds(0));
  ::close(p[1]);
  EXPECT_EQ(stream.stats().lines, 11u);
  // The first line went into the pipe before its reader left.
  EXPECT_EQ(stream.stats().dropped, 10u);
}

TEST(PoseStream, TheRateSelectsTheFirstStepOfEachPeriod) {
  int p[2];
  ASSERT_EQ(::pipe(p), 0);
  std::vector<JsonValue> got;
  std::thread reader([&] { got = read_lines(p[0]); });
  {
    PoseStream stream(p[1], kNames, 100.0);
    // Steps at 1 kHz from t = 0.5005 s: a line every tenth step.
    for (int k = 0; k < 100; ++k) {
      StepFixture f(0.5005 + k * 1e-3);
      stream.write(f.step);
    }
    stream.finish(std::chrono::milliseconds(5000));
    EXPECT_EQ(stream.stats().dropped, 0u);
  }
  ::close(p[1]);
  reader.join();
  ::close(p[0]);
  ASSERT_EQ(got.size(), 10u);
  for (std::size_t k = 0; k < got.size(); ++k) {
    EXPECT_NEAR(got[k]["t"].number(), 0.5005 + 0.01 * static_cast<double>(k), 1e-12);
    EXPECT_EQ(got[k]["seq"].number(), static_cast<double>(k));
  }
}

TEST(PoseStream, UdpLinesReachAListenerAndAnAbsentOneCostsNothing) {
  // A listener on an ephemeral port of the loopback.
  const int listener = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::bind(listener, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  socklen_t size = sizeof a;
  ASSERT_EQ(::getsockname(listener, reinterpret_cast<sockaddr*>(&a), &size), 0);
  const int port = ntohs(a.sin_port);
  {
    PoseStream stream("udp:127.0.0.1:" + std::to_string(port), kNames, 0.0);
    for (int k = 0; k < 3; ++k) {
      StepFixture f(k * 0.01);
      stream.write(f.step);
    }
    EXPECT_EQ(stream.stats().dropped, 0u);
  }
  for (int k = 0; k < 3; ++k) {
    pollfd pf{listener, POLLIN, 0};
    ASSERT_EQ(::poll(&pf, 1, 2000), 1);
    char buffer[8192];
    const ssize_t n = ::recv(listener, buffer, sizeof buffer, 0);
    ASSERT_GT(n, 0);
    const JsonValue j = JsonValue::parse(std::string_view(buffer, static_cast<std::size_t>(n)));
    EXPECT_EQ(j["seq"].number(), k);
    EXPECT_EQ(j["t"].number(), k * 0.01);
  }
  ::close(listener);
  // Nobody on the port now: sends are refused (ECONNREFUSED) or vanish, never wait.
  PoseStream absent("udp:127.0.0.1:" + std::to_string(port), kNames, 0.0);
  for (int k = 0; k < 100; ++k) {
    StepFixture f(k * 0.01);
    absent.write(f.step);
  }
  EXPECT_EQ(absent.stats().lines, 100u);
  EXPECT_GT(absent.stats().dropped, 0u) << "the refusals are counted";
}

TEST(PoseStream, BadTargetsAreRefusedWithTheFlag) {
  const auto error = [](const std::string& target) {
    try {
      PoseStream s(target, kNames, 0.0);
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error("pose.jsonl"),
            "--pose-out pose.jsonl: expected - (standard output) or "
            "udp:[HOST:]PORT");
  EXPECT_EQ(error("udp:127.0.0.1:0"),
            "--pose-out udp:127.0.0.1:0: expected udp:[HOST:]PORT, PORT in 1..65535");
  EXPECT_EQ(error("udp:127.0.0.1:port"),
            "--pose-out udp:127.0.0.1:port: expected udp:[HOST:]PORT, PORT in 1..65535");
  EXPECT_EQ(error("udp::9000"), "--pose-out udp::9000: expected udp:[HOST:]PORT, PORT in 1..65535");
}

}  // namespace
}  // namespace moa::io
