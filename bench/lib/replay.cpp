#include "moa_bench/replay.hpp"

#include <fmt/core.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <memory>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string_view>
#include <vector>

#include "moa/core/odometry.hpp"
#include "moa/core/sensor.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/json.hpp"
#include "moa/formats/mice_writer.hpp"
#include "moa/runs/odometry_run.hpp"
#include "moa_bench/bench_log.hpp"

namespace moa::bench {
namespace fs = std::filesystem;
namespace {

/// The floor any reader of mice.csv has to pay: the file read in 1 MiB
/// blocks, cut into lines and fields, t parsed with std::from_chars, the
/// integers too, the sensor name looked up; no checks. Returns a checksum
/// so that the work cannot be optimised away.
double parse_only(const fs::path& file, const std::vector<std::string>& names) {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> in(std::fopen(file.c_str(), "rb"), std::fclose);
  if (!in) throw std::runtime_error(fmt::format("{}: cannot open", file.string()));
  std::vector<char> block(std::size_t{1} << 20);
  std::size_t begin = 0, end = 0;
  bool header = true;
  double sum = 0.0;
  std::string_view fields[6];
  while (true) {
    const std::size_t n = std::fread(block.data() + end, 1, block.size() - end, in.get());
    end += n;
    const bool last = n == 0;
    while (true) {
      const char* start = block.data() + begin;
      const auto* nl = static_cast<const char*>(std::memchr(start, '\n', end - begin));
      if (!nl && !(last && begin < end)) break;
      const char* stop = nl ? nl : block.data() + end;
      begin = static_cast<std::size_t>(stop - block.data()) + (nl ? 1 : 0);
      const std::string_view line(start, static_cast<std::size_t>(stop - start));
      if (line.empty() || line[0] == '#') continue;
      if (header) {
        header = false;
        continue;
      }
      std::size_t count = 0, from = 0;
      while (count < 6) {
        const std::size_t comma = std::min(line.find(',', from), line.size());
        fields[count++] = line.substr(from, comma - from);
        if (comma == line.size()) break;
        from = comma + 1;
      }
      double t = 0.0;
      std::from_chars(fields[0].data(), fields[0].data() + fields[0].size(), t);
      const auto sensor = std::find(names.begin(), names.end(), fields[1]) - names.begin();
      sum += t + static_cast<double>(sensor);
      for (std::size_t f = 2; f < count; ++f) {
        std::int64_t v = 0;
        std::from_chars(fields[f].data(), fields[f].data() + fields[f].size(), v);
        sum += static_cast<double>(v);
      }
    }
    if (last) break;
    // Keep the partial line at the front of the block.
    std::memmove(block.data(), block.data() + begin, end - begin);
    end -= begin;
    begin = 0;
    if (end == block.size()) block.resize(2 * block.size());
  }
  return sum;
}

// s of CPU time of the calling thread: the replay's pipeline runs on it, the
// parse of mice.csv and the write of odometry.csv on threads of their own
// (runs/odometry_run.cpp), so this is the replay's critical path.
double thread_cpu() {
  timespec now{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &now);
  return static_cast<double>(now.tv_sec) + 1e-9 * static_cast<double>(now.tv_nsec);
}

template <class F>
void time_once(Timing& best, F&& run) {
  const auto wall0 = std::chrono::steady_clock::now();
  const std::clock_t cpu0 = std::clock();
  const double thread0 = thread_cpu();
  run();
  const double thread1 = thread_cpu();
  const std::clock_t cpu1 = std::clock();
  const auto wall1 = std::chrono::steady_clock::now();
  best.wall = std::min(best.wall, std::chrono::duration<double>(wall1 - wall0).count());
  best.cpu = std::min(best.cpu, static_cast<double>(cpu1 - cpu0) / CLOCKS_PER_SEC);
  best.thread = std::min(best.thread, thread1 - thread0);
}

volatile double g_checksum = 0.0;

}  // namespace

double ReplayBenchResult::real_time_factor() const { return duration / replay.wall; }

ReplayBenchResult run_replay_bench(const ReplayBenchOptions& args,
                                   const std::function<void(const std::string&)>& progress) {
  const auto say = [&](const std::string& line) {
    if (progress) progress(line);
  };
  const auto estimator = from_name<EstimatorKind>(args.estimator);
  // The log has mice.csv only: no wheels, no faults.
  if (!estimator || *estimator == EstimatorKind::kOracle || *estimator == EstimatorKind::kWheels) {
    throw std::invalid_argument(
        fmt::format("'{}' is not ls, sekimori or consensus (the log has no wheels and no faults)",
                    args.estimator));
  }
  const ScratchDir scratch(args.dir.empty() ? fs::temp_directory_path() : args.dir, args.keep_log);
  const io::RobotConfig config = four_sensors();
  say(fmt::format("writing a {} s log ...", args.duration));
  ReplayBenchResult result;
  result.log_dir = scratch.path();
  result.rows = write_log(config, args.duration, args.row_rate, scratch.path());
  const io::LogFiles log = io::resolve_log(scratch.path());
  result.mice_bytes = fs::file_size(log.mice);
  const std::string config_path = (scratch.path() / "robot.yaml").string();
  const fs::path out = scratch.path() / "odometry.csv";

  OdometryOptions options;
  options.estimator = *estimator;
  options.rate = args.epoch_rate;
  for (int r = 0; r < args.repeats; ++r) {
    say(fmt::format("run {} of {} ...", r + 1, args.repeats));
    time_once(result.parse, [&] { g_checksum = parse_only(log.mice, config.names); });
    time_once(result.replay, [&] {
      result.epochs = io::write_odometry(config, config_path, log, options, out).steps;
    });
  }
  result.odometry_bytes = fs::file_size(out);
  result.duration = args.duration;
  return result;
}

}  // namespace moa::bench
