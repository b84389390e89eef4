// mice.csv writer (io/mice_writer.hpp): what it writes reads back exactly
// through the log reader, both durabilities, and every refusal.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "moa/formats/config.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/log.hpp"
#include "moa/formats/mice_writer.hpp"
#include "support/error_of.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa::io {
namespace {

namespace fs = std::filesystem;
using Durability = MiceWriter::Durability;

using test::error_of;
using test::read_text;

RobotConfig config_ab() {
  return parse_config(
      "version: 1\n"
      "sensors:\n"
      "  - {name: a, position: [0.1, 0], yaw: 0, cpi: 800}\n"
      "  - {name: b, position: [-0.1, 0], yaw: 0, cpi: 800}\n",
      "robot.yaml");
}

SensorRow row(double t, int sensor, double dx, double dy, std::optional<std::uint8_t> squal = {},
              std::uint8_t flags = 0) {
  return SensorRow{t, sensor, {dx, dy}, squal, flags};
}

TEST(MiceWriter, RowsReadBackExactly) {
  const auto dir = test::scratch_dir("mice-writer");
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> step(0.0, 0.013);
  std::uniform_int_distribution<int> counts(-30000, 30000), sensor(0, 1), squal(0, 255);
  std::vector<SensorRow> rows;
  double t = 1234.5678;
  for (int i = 0; i < 2000; ++i) {
    t += step(rng);
    rows.push_back(row(t, sensor(rng), counts(rng), counts(rng),
                       i % 3 == 0 ? std::nullopt : std::optional<std::uint8_t>(squal(rng)),
                       static_cast<std::uint8_t>(i % 4)));
  }
  MiceWriter writer(dir / "mice.csv", {"a", "b"}, true, Durability::kWholeOrNothing, {"a comment"});
  for (const auto& r : rows) writer.write(r);
  EXPECT_FALSE(fs::exists(dir / "mice.csv"));
  writer.commit();
  EXPECT_EQ(writer.rows(), rows.size());

  MiceReader reader(dir, config_ab());
  EXPECT_EQ(reader.start_time(), rows.front().t);
  for (const auto& want : rows) {
    const auto got = reader.next();
    ASSERT_TRUE(got.has_value());
    EXPECT_EQ(got->t, want.t);  // exact: shortest round-trip text
    EXPECT_EQ(got->sensor, want.sensor);
    EXPECT_EQ(got->counts, want.counts);
    EXPECT_EQ(got->squal, want.squal);
    EXPECT_EQ(got->flags, want.flags);
  }
  EXPECT_FALSE(reader.next().has_value());
  fs::remove_all(dir);
}

TEST(MiceWriter, WritesTheDocumentedColumns) {
  const auto dir = test::scratch_dir("mice-writer");
  {
    MiceWriter writer(dir / "plain.csv", {"a", "b"}, false, Durability::kWholeOrNothing);
    writer.write(row(0.25, 1, -3, 4, 200, 1));
    writer.commit();
  }
  EXPECT_EQ(read_text(dir / "plain.csv"), "t,sensor,dx,dy\n0.25,b,-3,4\n");
  {
    MiceWriter writer(dir / "quality.csv", {"a", "b"}, true, Durability::kWholeOrNothing,
                      {"from a test"});
    writer.write(row(0.5, 0, 1, 2, 17, 2));
    writer.write(row(0.5, 1, 0, 0));
    writer.commit();
  }
  EXPECT_EQ(read_text(dir / "quality.csv"),
            "# from a test\nt,sensor,dx,dy,squal,flags\n0.5,a,1,2,17,2\n0.5,b,0,0,,0\n");
  fs::remove_all(dir);
}

TEST(MiceWriter, WholeOrNothingLeavesNothingWithoutCommit) {
  const auto dir = test::scratch_dir("mice-writer");
  {
    MiceWriter writer(dir / "mice.csv", {"a"}, false, Durability::kWholeOrNothing);
    writer.write(row(1, 0, 1, 1));
  }
  EXPECT_TRUE(fs::is_empty(dir));
  fs::remove_all(dir);
}

TEST(MiceWriter, JournalKeepsFlushedRowsWithoutCommit) {
  const auto dir = test::scratch_dir("mice-writer");
  {
    MiceWriter writer(dir / "mice.csv", {"a"}, false, Durability::kJournal);
    EXPECT_EQ(writer.partial_path(), dir / "mice.csv.part");
    writer.write(row(1, 0, 1, 1));
    writer.flush();
    EXPECT_EQ(read_text(dir / "mice.csv.part"), "t,sensor,dx,dy\n1,a,1,1\n");
  }
  EXPECT_TRUE(fs::exists(dir / "mice.csv.part"));
  EXPECT_FALSE(fs::exists(dir / "mice.csv"));
  {
    MiceWriter writer(dir / "mice.csv", {"a"}, false, Durability::kJournal);
    writer.write(row(2, 0, 5, 5));
    writer.commit();
  }
  EXPECT_FALSE(fs::exists(dir / "mice.csv.part"));
  EXPECT_EQ(read_text(dir / "mice.csv"), "t,sensor,dx,dy\n2,a,5,5\n");
  fs::remove_all(dir);
}

TEST(MiceWriter, RefusesRowsTheFormatCannotHold) {
  const auto dir = test::scratch_dir("mice-writer");
  const std::string file = (dir / "mice.csv").string();
  MiceWriter writer(dir / "mice.csv", {"a"}, false, Durability::kWholeOrNothing);
  writer.write(row(2, 0, 1, 1));
  EXPECT_EQ(error_of([&] { writer.write(row(1, 0, 1, 1)); }),
            file + ": time goes backwards (1 after 2)");
  EXPECT_EQ(error_of([&] { writer.write(row(3, 1, 1, 1)); }),
            file + ": row at t=3: no sensor with index 1");
  EXPECT_EQ(error_of([&] { writer.write(row(3, 0, 0.5, 1)); }),
            file + ": row at t=3: counts (0.5, 1) are not integers within 2^53");
  EXPECT_EQ(error_of([&] { writer.write(row(std::nan(""), 0, 1, 1)); }),
            file + ": row time is not finite (nan)");
  writer.commit();
  EXPECT_EQ(error_of([&] { writer.write(row(4, 0, 1, 1)); }), file + ": write after commit");
  EXPECT_EQ(error_of([&] { writer.commit(); }), file + ": already committed");
  EXPECT_EQ(error_of([&] { MiceWriter w(dir / "x.csv", {"a,b"}, false, Durability::kJournal); }),
            (dir / "x.csv").string() + ": invalid sensor name 'a,b'");
  fs::remove_all(dir);
}

}  // namespace
}  // namespace moa::io
