// The pipelined replay (io/odometry_run.cpp): mice.csv is parsed on a thread
// of its own and odometry.csv written on another, handed over in batches
// (io/batch_queue.hpp). What a caller sees must be what one thread gave: the
// same rows, the same error with the same "mice.csv:LINE", no file on error.
#include <fmt/core.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

// Internal to the io layer (not installed): included from the source tree.
#include "../src/runs/batch_queue.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/log.hpp"
#include "moa/formats/odometry_csv.hpp"
#include "moa/runs/odometry_run.hpp"
#include "support/error_of.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa::io {
namespace {

namespace fs = std::filesystem;
using test::error_of;
using test::read_text;

std::vector<std::string> read_lines(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

void write_lines(const fs::path& file, const std::vector<std::string>& lines) {
  std::ofstream out(file, std::ios::binary);
  for (const auto& line : lines) out << line << '\n';
}

// 20 s of 4 sensors at 1 kHz: 80 004 mice rows, many batches of each thread.
fs::path make_log(const std::string& tag) {
  const fs::path dir = test::scratch_dir(tag);
  const SensorArray array = test::skewed_array();
  test::write_log(test::synthesise(array, test::mixed_motion, 20.0, 0.001), array,
                  {"a", "b", "c", "d"}, dir);
  return dir;
}

OdometryOptions consensus_1k() {
  OdometryOptions options;
  options.estimator = EstimatorKind::kConsensus;
  options.rate = 1000.0;
  return options;
}

// mice.csv with line `line` (1-based) replaced by `text`.
void replace_line(const fs::path& mice, std::size_t line, const std::string& text) {
  auto lines = read_lines(mice);
  ASSERT_LT(line, lines.size());
  lines[line - 1] = text;
  write_lines(mice, lines);
}

std::size_t entries(const fs::path& dir) {
  std::size_t n = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++n;
  return n;
}

TEST(OdometryRunThreads, OutputIsTheRowsOfTheCallersThread) {
  const fs::path dir = make_log("run-threads-same");
  const std::string config_path = (dir / "robot.yaml").string();
  const RobotConfig config = read_config(config_path);
  const LogFiles log = resolve_log(dir);
  const OdometryOptions options = consensus_1k();

  // Through the writer thread.
  const OdometryRun threaded = write_odometry(config, config_path, log, options, dir / "a.csv");
  // Written on this thread, step by step, as in the sink.
  OdometryCsvWriter writer(dir / "b.csv", config.names, false);
  const OdometryRun direct = run_odometry(config, config_path, log, options,
                                          [&](const OdometryStep& step) { writer.write(step); });
  writer.commit();

  EXPECT_EQ(threaded.rows, 80'004u);
  EXPECT_EQ(threaded.rows, direct.rows);
  EXPECT_EQ(threaded.steps, direct.steps);
  EXPECT_EQ(threaded.t_end, direct.t_end);
  const std::string a = read_text(dir / "a.csv");
  EXPECT_GT(a.size(), 1'000'000u);
  EXPECT_TRUE(a == read_text(dir / "b.csv"));
}

TEST(OdometryRunThreads, LateParseErrorIsTheReadersErrorAfterItsRowsAndNoFile) {
  const fs::path dir = make_log("run-threads-parse");
  const std::string config_path = (dir / "robot.yaml").string();
  const RobotConfig config = read_config(config_path);
  const LogFiles log = resolve_log(dir);
  const std::size_t bad = read_lines(log.mice).size() - 3000;  // late: after many batches
  replace_line(log.mice, bad, "19.250000,a,x,3");

  // The error as one thread reading mice.csv gives it.
  const std::string expected = error_of([&] {
    MiceReader mice(log.mice, config);
    while (mice.next()) {
    }
  });
  ASSERT_EQ(expected.rfind(fmt::format("{}:{}: ", log.mice.string(), bad), 0), 0u) << expected;

  const std::size_t before = entries(dir);
  const fs::path out = dir / "odometry.csv";
  EXPECT_EQ(error_of([&] { write_odometry(config, config_path, log, consensus_1k(), out); }),
            expected);
  EXPECT_FALSE(fs::exists(out));
  EXPECT_EQ(entries(dir), before);  // no temporary left either

  // The rows before the error were all processed: the steps reach to about
  // the bad row's time (1 ms epochs; rows about 0.75 ms before it).
  double last = 0.0;
  EXPECT_EQ(error_of([&] {
              run_odometry(config, config_path, log, consensus_1k(),
                           [&](const OdometryStep& step) { last = step.t(); });
            }),
            expected);
  EXPECT_GT(last, 19.245);
}

TEST(OdometryRunThreads, LatePipelineErrorNamesItsLineAndLeavesNoFile) {
  const fs::path dir = make_log("run-threads-push");
  const std::string config_path = (dir / "robot.yaml").string();
  const RobotConfig config = read_config(config_path);
  const LogFiles log = resolve_log(dir);
  const std::size_t bad = read_lines(log.mice).size() - 2000;
  // Parses, but far beyond what a sensor tracks: refused by the pipeline.
  const auto lines = read_lines(log.mice);
  std::string row = lines[bad - 1];
  row = row.substr(0, row.find(',', row.find(',') + 1)) + ",100000000,0";
  replace_line(log.mice, bad, row);

  const fs::path out = dir / "odometry.csv";
  const std::string message =
      error_of([&] { write_odometry(config, config_path, log, consensus_1k(), out); });
  EXPECT_EQ(message.rfind(fmt::format("{}:{}: row at t = ", log.mice.string(), bad), 0), 0u)
      << message;
  EXPECT_FALSE(fs::exists(out));
}

// ------------------------------------------------------------- BatchQueue

TEST(BatchQueue, BatchesArriveInOrderAndWhole) {
  BatchQueue<int> queue(3, 7);
  constexpr int kCount = 10'000;
  std::thread producer([&] {
    std::vector<int>* batch = nullptr;
    for (int i = 0; i < kCount; ++i) {
      if (batch == nullptr) batch = queue.acquire();
      batch->push_back(i);
      if (batch->size() == queue.capacity()) {
        queue.submit();
        batch = nullptr;
      }
    }
    if (batch != nullptr) queue.submit();
    queue.close();
  });
  std::vector<int> got;
  while (const auto* batch = queue.next()) {
    got.insert(got.end(), batch->begin(), batch->end());
    queue.release();
  }
  producer.join();
  ASSERT_EQ(got.size(), static_cast<std::size_t>(kCount));
  for (int i = 0; i < kCount; ++i) EXPECT_EQ(got[static_cast<std::size_t>(i)], i);
}

TEST(BatchQueue, ProducersErrorComesAfterItsBatches) {
  BatchQueue<int> queue(2, 4);
  std::thread producer([&] {
    for (int b = 0; b < 5; ++b) {
      auto* batch = queue.acquire();
      batch->assign({b, b, b});
      queue.submit();
    }
    queue.close(std::make_exception_ptr(Error("mice.csv:9: bad")));
  });
  int batches = 0;
  const std::string message = error_of([&] {
    while (const auto* batch = queue.next()) {
      EXPECT_EQ(batch->front(), batches);
      ++batches;
      queue.release();
    }
  });
  producer.join();
  EXPECT_EQ(batches, 5);
  EXPECT_EQ(message, "mice.csv:9: bad");
}

TEST(BatchQueue, ConsumersErrorReachesTheProducerAtItsNextAcquire) {
  BatchQueue<int> queue(2, 4);
  std::thread consumer([&] {
    queue.next();
    queue.stop(std::make_exception_ptr(Error("odometry.csv: disk full")));
  });
  // The producer fills batches until the ring refuses one.
  const std::string message = error_of([&] {
    for (int i = 0; i < 100; ++i) {
      if (queue.acquire() == nullptr) break;
      queue.submit();
    }
  });
  consumer.join();
  EXPECT_EQ(message, "odometry.csv: disk full");
}

TEST(BatchQueue, StopWakesAWaitingConsumer) {
  BatchQueue<int> queue(2, 4);
  const std::vector<int> unset;
  const std::vector<int>* got = &unset;
  std::thread consumer([&] { got = queue.next(); });
  queue.stop();
  consumer.join();
  EXPECT_EQ(got, nullptr);
}

}  // namespace
}  // namespace moa::io
