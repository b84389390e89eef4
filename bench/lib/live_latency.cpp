#include "moa_bench/live_latency.hpp"

#include <fmt/core.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <thread>

#include "moa/core/names.hpp"
#include "moa/core/odometry.hpp"
#include "moa/runs/live_source.hpp"
#include "moa/runs/pose_stream.hpp"
#include "moa/runs/run_loop.hpp"
#include "moa/sources/replay_reader.hpp"
#include "moa_bench/bench_log.hpp"

namespace moa::bench {
namespace fs = std::filesystem;
namespace {

/// A UDP socket on an ephemeral port of the loopback: the reader of the
/// pose stream. `drain`: a thread of its own waits for each line (woken by
/// every one); else nothing reads (a stalled reader: the kernel discards
/// what its receive buffer cannot hold).
class PoseListener {
 public:
  explicit PoseListener(bool drain) {
    fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t size = sizeof a;
    if (fd_ < 0 || ::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
        ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &size) != 0) {
      throw std::runtime_error("moa bench --live: cannot bind a UDP socket on the loopback");
    }
    port_ = ntohs(a.sin_port);
    if (!drain) return;
    thread_ = std::thread([this] {
      char buffer[65536];
      while (!stop_) {
        pollfd p{fd_, POLLIN, 0};
        if (::poll(&p, 1, 50) <= 0) continue;
        if (::recv(fd_, buffer, sizeof buffer, 0) > 0) ++received_;
      }
    });
  }
  ~PoseListener() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
    ::close(fd_);
  }
  PoseListener(const PoseListener&) = delete;
  PoseListener& operator=(const PoseListener&) = delete;
  int port() const { return port_; }
  std::size_t received() const { return received_; }

 private:
  int fd_ = -1;
  int port_ = 0;
  std::atomic<bool> stop_{false};
  std::atomic<std::size_t> received_{0};
  std::thread thread_;
};

/// The q-quantile of `v` (sorted in place): the smallest value with at least
/// q of the values at or below it.
double quantile(std::vector<double>& v, double q) {
  std::sort(v.begin(), v.end());
  const auto k = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size())));
  return v[std::clamp<std::size_t>(k, 1, v.size()) - 1];
}

}  // namespace

std::vector<LiveLatency> run_live_latency_bench(
    const LiveLatencyOptions& args, const std::function<void(const std::string&)>& progress) {
  const auto say = [&](const std::string& line) {
    if (progress) progress(line);
  };
  const auto estimator = from_name<EstimatorKind>(args.estimator);
  if (!estimator || *estimator == EstimatorKind::kOracle || *estimator == EstimatorKind::kWheels) {
    throw std::invalid_argument(
        fmt::format("'{}' is not ls, sekimori or consensus (the log has no wheels and no faults)",
                    args.estimator));
  }
  const io::RobotConfig config = four_sensors();
  std::vector<LiveLatency> results;
  for (const bool drain : {true, false}) {
    for (const double rate : args.rates) {
      const ScratchDir scratch(args.dir.empty() ? fs::temp_directory_path() : args.dir);
      write_log(config, args.duration, rate, scratch.path());
      const std::string config_path = (scratch.path() / "robot.yaml").string();
      say(fmt::format("{} Hz, reader {}: replaying {} s of four sensors in real time ...", rate,
                      drain ? "reading" : "stalled", args.duration));

      // As `moa live --replay DIR --rate RATE --pose-out udp:127.0.0.1:PORT`.
      OdometryOptions options;
      options.estimator = *estimator;
      options.rate = rate;
      options.max_gap = std::numeric_limits<double>::infinity();
      PoseListener listener(drain);
      io::PoseStream stream(fmt::format("udp:127.0.0.1:{}", listener.port()), config.names, 0.0);
      io::ReplayReader replay(scratch.path(), config, io::ReplayOptions{}, io::LiveHooks{});
      io::LiveRunSource input(replay, config.array.size(), scratch.path().string());
      std::vector<double> latency;
      latency.reserve(static_cast<std::size_t>(args.duration * rate) + 16);
      io::RunCallbacks callbacks;
      callbacks.on_step = [&](const OdometryStep& step) {
        stream.write(step);
        const auto written = std::chrono::steady_clock::now();
        // The last one or two steps (Odometry::finish, at the end of the
        // stream) count from the last row too.
        latency.push_back(std::chrono::duration<double>(written - input.last_arrival()).count());
      };
      io::run_loop(config, config_path, options, input, scratch.path().string(), callbacks);
      // The reader's last datagrams (up to 2 s for a thread kept off the CPU).
      const std::size_t sent = stream.stats().lines - stream.stats().dropped;
      for (int k = 0; drain && k < 200 && listener.received() < sent; ++k) {
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
      LiveLatency r;
      r.rate_hz = rate;
      r.reader_reading = drain;
      r.steps = latency.size();
      r.lines_received = listener.received();
      r.lines_dropped = stream.stats().dropped;
      if (!latency.empty()) {
        r.max_s = *std::max_element(latency.begin(), latency.end());
        r.p99_s = quantile(latency, 0.99);
        r.p50_s = quantile(latency, 0.5);
      }
      results.push_back(r);
    }
  }
  return results;
}

}  // namespace moa::bench
