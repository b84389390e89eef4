// moa bench: median cost per update of moa's estimators against the
// literal formulations, and --replay: moa odometry against a parse-only
// pass. The measurements are the benchmarks' library (bench/lib); this
// file has the flags and the printing.
#include <fmt/core.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <memory>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "commands.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/json.hpp"
#include "moa_bench/estimators.hpp"
#include "moa_bench/live_latency.hpp"
#include "moa_bench/replay.hpp"
#include "odometry_options.hpp"

namespace moa::cli {
namespace {

struct BenchArgs {
  bench::EstimatorBenchOptions estimators;
  bool json = false;
  bool replay = false;
  bench::ReplayBenchOptions replay_options;
  bool live = false;
  bench::LiveLatencyOptions live_options;
};

int run_bench(const BenchArgs& args) {
  using Row = bench::EstimatorCosts;
  const std::vector<Row> rows = bench::bench_estimators(
      args.estimators,
      args.json ? nullptr : +[](int n) { fmt::print(stderr, "moa bench: N = {} ...\n", n); });
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
        .member("consensus_over_sekimori", four.consensus / four.sekimori)
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
        .member("cpu", bench::cpu_model())
        .member("hardware_threads", static_cast<std::uint64_t>(std::thread::hardware_concurrency()))
        .end_object()
        .member("compiler", __VERSION__)
        .member("build", build)
        .member("batches", args.estimators.batches)
        .member("updates_per_batch", args.estimators.updates)
        .end_object();
    fmt::print("{}\n", json.str());
    return 0;
  }
  fmt::print("median ns per update ({} batches of {} updates; {}; {})\n", args.estimators.batches,
             args.estimators.updates, bench::cpu_model(), build);
  // consensus / sekimori: the robust estimator's cost against the paper's
  // voting over the same sensors, measured in the same run.
  fmt::print("{:>3} | {:>9} {:>9} {:>7} | {:>9} {:>14} {:>7} | {:>9} {:>10}\n", "N", "ls",
             "naive_ls", "ratio", "sekimori", "naive_sekimori", "ratio", "consensus", "/sekimori");
  for (const Row& r : rows) {
    fmt::print(
        "{:>3} | {:>9.1f} {:>9.1f} {:>7.1f} | {:>9.1f} {:>14.1f} {:>7.1f} | {:>9.1f} {:>10.2f}\n",
        r.n, r.ls, r.naive_ls, r.naive_ls / r.ls, r.sekimori, r.naive_sekimori,
        r.naive_sekimori / r.sekimori, r.consensus, r.consensus / r.sekimori);
  }
  return 0;
}

int run_replay_bench(const bench::ReplayBenchOptions& args, bool json_out) {
  bench::ReplayBenchResult result;
  try {
    result = bench::run_replay_bench(args, [&](const std::string& line) {
      if (!json_out) fmt::print(stderr, "moa bench --replay: {}\n", line);
    });
  } catch (const std::invalid_argument& e) {
    throw io::Error(fmt::format("--estimator: {}", e.what()));
  }
  const bench::Timing& parse = result.parse;
  const bench::Timing& replay = result.replay;
  const double real_time = result.real_time_factor();
  const double ratio = replay.wall / parse.wall;
  const double cpu_ratio = replay.cpu / parse.cpu;
  if (json_out) {
    // Units in the keys: s, bytes, Hz; ratios and counts are plain numbers.
    io::JsonWriter json;
    json.begin_object()
        .member("duration_s", args.duration)
        .member("mice_rows", static_cast<std::uint64_t>(result.rows))
        .member("mice_bytes", static_cast<std::uint64_t>(result.mice_bytes))
        .member("epochs", static_cast<std::uint64_t>(result.epochs))
        .member("odometry_bytes", static_cast<std::uint64_t>(result.odometry_bytes))
        .member("estimator", args.estimator)
        .member("rate_hz", args.epoch_rate)
        .member("repeats", args.repeats)
        .member("parse_only_s", parse.wall)
        .member("parse_only_cpu_s", parse.cpu)
        .member("replay_s", replay.wall)
        .member("replay_cpu_s", replay.cpu)
        .member("replay_main_thread_cpu_s", replay.thread)
        .member("real_time_factor", real_time)
        .member("replay_over_parse", ratio)
        .member("replay_over_parse_cpu", cpu_ratio)
        .end_object();
    fmt::print("{}\n", json.str());
    return 0;
  }
  fmt::print("log: {} s, {} mice rows ({:.1f} MB), 4 sensors at {} Hz\n", args.duration,
             result.rows, static_cast<double>(result.mice_bytes) / 1e6, args.row_rate);
  fmt::print(
      "replay: moa odometry --estimator {} --rate {}: {} epochs, {:.1f} MB of odometry.csv\n",
      args.estimator, args.epoch_rate, result.epochs,
      static_cast<double>(result.odometry_bytes) / 1e6);
  fmt::print("best of {}        wall s    CPU s   main thread CPU s\n", args.repeats);
  fmt::print("parse-only      {:8.3f} {:8.3f} {:8.3f}\n", parse.wall, parse.cpu, parse.thread);
  fmt::print("replay          {:8.3f} {:8.3f} {:8.3f}\n", replay.wall, replay.cpu, replay.thread);
  fmt::print("real-time factor {:.0f}x; replay / parse-only {:.2f} (wall), {:.2f} (CPU)\n",
             real_time, ratio, cpu_ratio);
  if (args.keep_log) fmt::print("log kept in {}\n", result.log_dir.string());
  return 0;
}

int run_live_bench(const bench::LiveLatencyOptions& args, bool json_out) {
  std::vector<bench::LiveLatency> results;
  try {
    results = bench::run_live_latency_bench(args, [&](const std::string& line) {
      if (!json_out) fmt::print(stderr, "moa bench --live: {}\n", line);
    });
  } catch (const std::invalid_argument& e) {
    throw io::Error(fmt::format("--estimator: {}", e.what()));
  }
  if (json_out) {
    // Keys: s, Hz; counts plain.
    io::JsonWriter json;
    json.begin_object();
    // "latency": with a reader woken by every line; "latency_reader_stalled":
    // the same with nobody reading.
    for (const bool reading : {true, false}) {
      json.key(reading ? "latency" : "latency_reader_stalled").begin_array();
      for (const auto& r : results) {
        if (r.reader_reading != reading) continue;
        json.begin_object()
            .member("rate_hz", r.rate_hz)
            .member("p50_s", r.p50_s)
            .member("p99_s", r.p99_s)
            .member("max_s", r.max_s)
            .member("steps", static_cast<std::uint64_t>(r.steps))
            .member("lines_received", static_cast<std::uint64_t>(r.lines_received))
            .member("lines_dropped", static_cast<std::uint64_t>(r.lines_dropped))
            .end_object();
      }
      json.end_array();
    }
    json.member("sensors", 4)
        .member("duration_s", args.duration)
        .member("estimator", args.estimator)
        .member("cpu", bench::cpu_model())
        .end_object();
    fmt::print("{}\n", json.str());
    return 0;
  }
  fmt::print(
      "from a mice row's arrival to its pose line sent (UDP, loopback); 4 sensors, {} s each, "
      "estimator {}; {}\n",
      args.duration, args.estimator, bench::cpu_model());
  fmt::print("{:>8} {:>8} {:>7} {:>10} {:>10} {:>10} {:>9} {:>8}\n", "reader", "rate Hz", "steps",
             "p50 us", "p99 us", "max us", "received", "dropped");
  for (const auto& r : results) {
    fmt::print("{:>8} {:>8} {:>7} {:>10.1f} {:>10.1f} {:>10.1f} {:>9} {:>8}\n",
               r.reader_reading ? "reading" : "stalled", r.rate_hz, r.steps, 1e6 * r.p50_s,
               1e6 * r.p99_s, 1e6 * r.max_s, r.lines_received, r.lines_dropped);
  }
  return 0;
}

}  // namespace

void add_bench(CLI::App& app, Action& action) {
  auto args = std::make_shared<BenchArgs>();
  auto* cmd = app.add_subcommand(
      "bench", "Cost per update of the estimators against the literal formulations (ns)");
  cmd->add_option("--batches", args->estimators.batches,
                  "Timed batches per estimator (median is reported)")
      ->check(kPositive)
      ->capture_default_str();
  cmd->add_option("--updates", args->estimators.updates, "Updates per batch")
      ->check(kPositive)
      ->capture_default_str();
  cmd->add_option("--sizes", args->estimators.sizes, "Numbers of sensors to measure (2..16)")
      ->delimiter(',')
      ->check(CLI::Range(2, kMaxSensors))
      ->capture_default_str();
  cmd->add_flag("--json", args->json, "One JSON object on stdout");
  auto& r = args->replay_options;
  cmd->add_flag("--replay", args->replay,
                "Instead: moa odometry over a generated log against a parse-only pass of its "
                "mice.csv (best of --repeats; the log is written to a temporary directory and "
                "removed)");
  auto* duration = cmd->add_option("--duration", r.duration,
                                   "--replay: seconds of log; --live: seconds at each rate "
                                   "(default 5)")
                       ->check(finite_within(1.0, 3600.0))
                       ->capture_default_str();
  cmd->add_flag(
      "--live", args->live,
      "Instead: latency of `moa live` from a mice row's arrival to its pose line sent "
      "(--pose-out udp:), median and 99th percentile, four sensors replayed in real "
      "time at 100 Hz and 1 kHz (rows per sensor and epochs), with a reader reading each line "
      "and with one stalled; takes 4 x --duration s");
  cmd->add_option("--row-rate", r.row_rate, "--replay: mice rows per second per sensor")
      ->check(finite_within(1.0, 10000.0))
      ->capture_default_str();
  cmd->add_option("--rate", r.epoch_rate, "--replay: epochs per second (moa odometry --rate)")
      ->check(finite_within(1.0, 10000.0))
      ->capture_default_str();
  cmd->add_option("--estimator", r.estimator, "--replay, --live: ls, sekimori or consensus")
      ->capture_default_str();
  cmd->add_option("--repeats", r.repeats, "--replay: timed runs of each pass (best is reported)")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  cmd->add_option("--dir", r.dir,
                  "--replay, --live: directory for the temporary log (default: system temp)")
      ->check(CLI::ExistingDirectory);
  cmd->add_flag("--keep-log", r.keep_log,
                "--replay: keep the log (robot.yaml, mice.csv, odometry.csv) and print its "
                "directory");
  cmd->callback([&action, args, duration] {
    action = [args, live_duration = duration->count() != 0] {
      if (args->live) {
        args->live_options.estimator = args->replay_options.estimator;
        if (live_duration) args->live_options.duration = args->replay_options.duration;
        args->live_options.dir = args->replay_options.dir;
        return run_live_bench(args->live_options, args->json);
      }
      if (!args->replay) return run_bench(*args);
      return run_replay_bench(args->replay_options, args->json);
    };
  });
}

}  // namespace moa::cli
