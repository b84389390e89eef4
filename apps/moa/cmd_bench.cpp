// moa bench: median cost per update of moa's estimators against the
// literal formulations, all in one process so that the ratios are fair.
#include <fmt/core.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <memory>
#include <numbers>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "baselines.hpp"
#include "bench_replay.hpp"
#include "commands.hpp"
#include "moa/core/consensus.hpp"
#include "moa/core/estimate.hpp"
#include "moa/core/sekimori.hpp"
#include "moa/formats/json.hpp"
#include "odometry_options.hpp"

namespace moa::cli {
namespace {

struct BenchArgs {
  int batches = 31;
  int updates = 2000;
  std::vector<int> sizes{2, 4, 8};
  bool json = false;
  bool replay = false;
  ReplayBenchArgs replay_args;
};

/// N sensors radial around the robot (Sekimori & Miyazaki's layout), HDNS-2051.
SensorArray radial_array(int n) {
  std::vector<SensorMount> mounts(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const double phi = std::numbers::pi / 4.0 + i * 2.0 * std::numbers::pi / n;
    auto& m = mounts[static_cast<std::size_t>(i)];
    m.position = 0.1 * Eigen::Vector2d(std::cos(phi), std::sin(phi));
    m.yaw = phi;
    m.cpi = kHdns2051.cpi;
    m.max_speed = kHdns2051.max_speed;
  }
  return SensorArray(mounts);
}

/// 100 Hz samples of random motion, quantised; one in ten has a sensor that lost track.
std::vector<ArraySample> workload(const SensorArray& array, std::size_t count) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> v(-0.3, 0.3), w(-1.5, 1.5);
  std::vector<ArraySample> samples(count);
  for (std::size_t k = 0; k < count; ++k) {
    ArraySample& s = samples[k];
    s.t = 0.01 * static_cast<double>(k + 1);
    s.dt = 0.01;
    s.size = array.size();
    const Twist2 x{{v(rng), v(rng)}, w(rng)};
    for (int i = 0; i < array.size(); ++i) {
      const auto u = static_cast<std::size_t>(i);
      s.counts[u] = array[i].counts(x, s.dt).array().round();
      s.squal[u] = 255;
    }
    if (k % 10 == 3) s.counts[k % static_cast<std::size_t>(array.size())] *= 0.3;
  }
  return samples;
}

/// Results land here so that the optimiser cannot drop the work.
volatile double g_sink = 0.0;

/// Median over batches of the time per update (ns).
template <class F>
double median_ns(const BenchArgs& args, const std::vector<ArraySample>& samples, F&& update) {
  std::vector<double> per_update;
  double sink = 0.0;
  for (int b = 0; b < args.batches; ++b) {
    const auto start = std::chrono::steady_clock::now();
    for (int k = 0; k < args.updates; ++k) {
      sink += update(samples[static_cast<std::size_t>(k) % samples.size()]);
    }
    const auto stop = std::chrono::steady_clock::now();
    per_update.push_back(std::chrono::duration<double, std::nano>(stop - start).count() /
                         args.updates);
  }
  g_sink = sink;
  std::nth_element(per_update.begin(), per_update.begin() + args.batches / 2, per_update.end());
  return per_update[static_cast<std::size_t>(args.batches / 2)];
}

struct Row {
  int n;
  double ls, naive_ls, sekimori, naive_sekimori, consensus;
};

Row bench_n(const BenchArgs& args, int n) {
  const SensorArray array = radial_array(n);
  const auto samples = workload(array, 64);
  const auto ls = std::get<LsEstimator>(LsEstimator::create(array, all_sensors(n), 0.01));
  auto sekimori = std::get<SekimoriEstimator>(SekimoriEstimator::create(array));
  auto consensus = std::get<ConsensusEstimator>(ConsensusEstimator::create(array));
  const int r_th = sekimori.r_th();
  const double e_th = SekimoriOptions{}.e_th;
  Row r{n, 0, 0, 0, 0, 0};
  r.ls =
      median_ns(args, samples, [&](const ArraySample& s) { return ls.estimate(s)->twist.omega; });
  r.naive_ls = median_ns(args, samples,
                         [&](const ArraySample& s) { return baseline::naive_ls(array, s).omega; });
  r.sekimori = median_ns(args, samples, [&](const ArraySample& s) {
    return sekimori.estimate(s)->estimate.twist.omega;
  });
  r.naive_sekimori = median_ns(args, samples, [&](const ArraySample& s) {
    return baseline::naive_sekimori(array, s, e_th, r_th).omega;
  });
  r.consensus = median_ns(args, samples, [&](const ArraySample& s) {
    return consensus.estimate(s)->estimate.twist.omega;
  });
  return r;
}

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      if (colon != std::string::npos) return line.substr(colon + 2);
    }
  }
  return "unknown";
}

int run_bench(const BenchArgs& args) {
  std::vector<Row> rows;
  for (int n : args.sizes) {
    if (!args.json) fmt::print(stderr, "moa bench: N = {} ...\n", n);
    rows.push_back(bench_n(args, n));
  }
  // The headline figures are for N = 4 (or the last size measured).
  const Row& four = *std::find_if(rows.begin(), rows.end(),
                                  [&](const Row& r) { return r.n == 4 || &r == &rows.back(); });
#ifdef NDEBUG
  const char* build = "optimised (NDEBUG)";
#else
  const char* build = "debug (assertions on): figures are not representative";
#endif
  if (args.json) {
    // Keys: nanoseconds per update (ns), ratios (1).
    const auto timings = [](io::JsonWriter& json, const Row& r) {
      json.member("n", r.n)
          .member("ls_ns_per_update", r.ls)
          .member("naive_ls_ns_per_update", r.naive_ls)
          .member("sekimori_ns_per_update", r.sekimori)
          .member("naive_sekimori_ns_per_update", r.naive_sekimori)
          .member("consensus_ns_per_update", r.consensus);
    };
    io::JsonWriter json;
    json.begin_object();
    timings(json, four);
    json.member("ls_speedup", four.naive_ls / four.ls)
        .member("sekimori_speedup", four.naive_sekimori / four.sekimori)
        .member("consensus_vs_naive_ls", four.naive_ls / four.consensus)
        .key("per_n")
        .begin_array();
    for (const Row& r : rows) {
      json.begin_object();
      timings(json, r);
      json.end_object();
    }
    json.end_array()
        .key("machine")
        .begin_object()
        .member("cpu", cpu_model())
        .member("hardware_threads", static_cast<std::uint64_t>(std::thread::hardware_concurrency()))
        .end_object()
        .member("compiler", __VERSION__)
        .member("build", build)
        .member("batches", args.batches)
        .member("updates_per_batch", args.updates)
        .end_object();
    fmt::print("{}\n", json.str());
    return 0;
  }
  fmt::print("median ns per update ({} batches of {} updates; {}; {})\n", args.batches,
             args.updates, cpu_model(), build);
  fmt::print("{:>3} | {:>9} {:>9} {:>7} | {:>9} {:>14} {:>7} | {:>9}\n", "N", "ls", "naive_ls",
             "ratio", "sekimori", "naive_sekimori", "ratio", "consensus");
  for (const Row& r : rows) {
    fmt::print("{:>3} | {:>9.1f} {:>9.1f} {:>7.1f} | {:>9.1f} {:>14.1f} {:>7.1f} | {:>9.1f}\n", r.n,
               r.ls, r.naive_ls, r.naive_ls / r.ls, r.sekimori, r.naive_sekimori,
               r.naive_sekimori / r.sekimori, r.consensus);
  }
  return 0;
}

}  // namespace

void add_bench(CLI::App& app, Action& action) {
  auto args = std::make_shared<BenchArgs>();
  auto* cmd = app.add_subcommand(
      "bench", "Cost per update of the estimators against the literal formulations (ns)");
  cmd->add_option("--batches", args->batches, "Timed batches per estimator (median is reported)")
      ->check(kPositive)
      ->capture_default_str();
  cmd->add_option("--updates", args->updates, "Updates per batch")
      ->check(kPositive)
      ->capture_default_str();
  cmd->add_option("--sizes", args->sizes, "Numbers of sensors to measure (2..16)")
      ->delimiter(',')
      ->check(CLI::Range(2, kMaxSensors))
      ->capture_default_str();
  cmd->add_flag("--json", args->json, "One JSON object on stdout");
  auto& r = args->replay_args;
  cmd->add_flag("--replay", args->replay,
                "Instead: moa odometry over a generated log against a parse-only pass of its "
                "mice.csv (best of --repeats; the log is written to a temporary directory and "
                "removed)");
  cmd->add_option("--duration", r.duration, "--replay: seconds of log")
      ->check(finite_within(1.0, 3600.0))
      ->capture_default_str();
  cmd->add_option("--row-rate", r.row_rate, "--replay: mice rows per second per sensor")
      ->check(finite_within(1.0, 10000.0))
      ->capture_default_str();
  cmd->add_option("--rate", r.epoch_rate, "--replay: epochs per second (moa odometry --rate)")
      ->check(finite_within(1.0, 10000.0))
      ->capture_default_str();
  cmd->add_option("--estimator", r.estimator, "--replay: ls, sekimori or consensus")
      ->capture_default_str();
  cmd->add_option("--repeats", r.repeats, "--replay: timed runs of each pass (best is reported)")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  cmd->add_option("--dir", r.dir,
                  "--replay: directory for the temporary log (default: system temp)")
      ->check(CLI::ExistingDirectory);
  cmd->add_flag("--keep-log", r.keep_log,
                "--replay: keep the log (robot.yaml, mice.csv, odometry.csv) and print its "
                "directory");
  cmd->callback([&action, args] {
    action = [args] {
      if (!args->replay) return run_bench(*args);
      ReplayBenchArgs replay = args->replay_args;
      replay.json = args->json;
      return run_replay_bench(replay);
    };
  });
}

}  // namespace moa::cli
