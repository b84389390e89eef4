// evemu recordings (io/evemu.hpp) and `moa import-evemu`: real recordings
// keep every count, both file layouts, frames grouped by SYN_REPORT, and
// each malformed input rejected with its exact "FILE:LINE: what".
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "moa/formats/error.hpp"
#include "moa/sources/evemu.hpp"
#include "support/error_of.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa::io {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

const fs::path kData = fs::path(MOA_TEST_DATA_DIR) / "evemu";

using test::error_of;

fs::path write_file(const fs::path& file, const std::string& text) {
  std::ofstream(file, std::ios::binary) << text;
  return file;
}

// What a recording holds, by a plain line scan written for this test: every
// "E:" line's fields, values through std::stoll in base 10.
struct Scan {
  std::int64_t sum_x = 0;
  std::int64_t sum_y = 0;
  std::size_t motion_frames = 0;  // SYN_REPORTs closing a frame with nonzero REL_X/REL_Y
};

Scan scan(const fs::path& file) {
  std::ifstream in(file);
  std::string line;
  Scan s;
  bool motion = false;
  while (std::getline(in, line)) {
    if (line.rfind("E:", 0) != 0) continue;
    std::istringstream fields(line);
    std::string tag, time, type, code, value;
    fields >> tag >> time >> type >> code >> value;
    const long long v = std::stoll(value, nullptr, 10);
    if (type == "0002" && code == "0000") s.sum_x += v;
    if (type == "0002" && code == "0001") s.sum_y += v;
    if (type == "0002" && (code == "0000" || code == "0001") && v != 0) motion = true;
    if (type == "0000" && code == "0000") {
      if (motion) ++s.motion_frames;
      motion = false;
    }
  }
  return s;
}

struct Totals {
  std::int64_t dx = 0;
  std::int64_t dy = 0;
  std::size_t rows = 0;
};

std::vector<Totals> read_all_rows(EvemuReader& reader, int inputs) {
  std::vector<Totals> totals(static_cast<std::size_t>(inputs));
  double last = 0.0;
  while (const auto row = reader.next()) {
    EXPECT_GE(row->t, last);
    last = row->t;
    auto& t = totals.at(static_cast<std::size_t>(row->sensor));
    t.dx += static_cast<std::int64_t>(row->counts.x());
    t.dy += static_cast<std::int64_t>(row->counts.y());
    ++t.rows;
  }
  return totals;
}

// ------------------------------------------------------- real recordings

struct Recording {
  const char* file;
  std::size_t frames;  // from the data set's README
  std::int64_t sum_x;
  std::int64_t sum_y;
};

class RealRecording : public ::testing::TestWithParam<Recording> {};

TEST_P(RealRecording, KeepsEveryCount) {
  const Recording& r = GetParam();
  const Scan expected = scan(kData / r.file);
  // The independent scan agrees with the numbers the data set documents.
  EXPECT_EQ(expected.motion_frames, r.frames);
  EXPECT_EQ(expected.sum_x, r.sum_x);
  EXPECT_EQ(expected.sum_y, r.sum_y);

  EvemuReader reader({{"m", kData / r.file}});
  EXPECT_EQ(reader.start_time(), 0.0);
  const auto totals = read_all_rows(reader, 1);
  EXPECT_EQ(totals[0].dx, expected.sum_x);
  EXPECT_EQ(totals[0].dy, expected.sum_y);
  EXPECT_EQ(totals[0].rows, expected.motion_frames);
  const EvemuStats& stats = reader.stats(0);
  EXPECT_EQ(stats.sum_dx, expected.sum_x);
  EXPECT_EQ(stats.sum_dy, expected.sum_y);
  EXPECT_EQ(stats.frames, expected.motion_frames);
  EXPECT_FALSE(stats.unterminated);
}

INSTANTIATE_TEST_SUITE_P(DataSet, RealRecording,
                         ::testing::Values(Recording{"ps2-generic-mouse.events", 2707, -5424, -929},
                                           Recording{"ultrathin-touch-mouse.events", 349, -319,
                                                     -7}),
                         [](const ::testing::TestParamInfo<Recording>& p) {
                           return std::string(p.param.file[0] == 'p' ? "OldStylePs2"
                                                                     : "NewStyleUltrathin");
                         });

TEST(EvemuReader, ReadsTheDeviceNameOfBothLayouts) {
  EvemuReader old_style({{"a", kData / "ps2-generic-mouse.events"}});
  EXPECT_EQ(old_style.stats(0).device, "PS/2 Generic Mouse");
  EvemuReader new_style({{"b", kData / "ultrathin-touch-mouse.events"}});
  EXPECT_EQ(new_style.stats(0).device, "Ultrathin Touch Mouse");
}

TEST(EvemuReader, AcceptsTheDescriptionPathOfAnOldStyleRecording) {
  EvemuReader reader({{"m", kData / "ps2-generic-mouse.desc"}});
  EXPECT_EQ(reader.stats(0).events, kData / "ps2-generic-mouse.events");
  const auto totals = read_all_rows(reader, 1);
  EXPECT_EQ(totals[0].dx, scan(kData / "ps2-generic-mouse.events").sum_x);
}

TEST(EvemuReader, AcceptsTheCommonStemOfAnOldStylePair) {
  EvemuReader reader({{"m", kData / "ps2-generic-mouse"}});
  EXPECT_EQ(reader.stats(0).events, kData / "ps2-generic-mouse.events");
  EXPECT_EQ(reader.stats(0).device, "PS/2 Generic Mouse");
}

TEST(EvemuReader, FirstRowOfTheOldRecordingIsAtItsSynReport) {
  // E: 1329846856.201613 0002 0001 -1, then the SYN_REPORT at .201621.
  EvemuReader reader({{"m", kData / "ps2-generic-mouse.events"}});
  const auto row = reader.next();
  ASSERT_TRUE(row.has_value());
  EXPECT_DOUBLE_EQ(row->t, 8e-6);
  EXPECT_EQ(row->counts.x(), 0.0);
  EXPECT_EQ(row->counts.y(), -1.0);
}

// --------------------------------------------------------- synthetic files

class EvemuFiles : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = test::scratch_dir("evemu"); }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path file(const std::string& name, const std::string& text) {
    return write_file(dir_ / name, text);
  }
  fs::path dir_;
};

TEST_F(EvemuFiles, ValuesAreBaseTenWhateverTheirLeadingZeros) {
  const auto f = file("z.events",
                      "E: 0.000000 0002 0000 0010\n"
                      "E: 0.000000 0002 0001 -013\n"
                      "E: 0.000000 0000 0000 0000\n"
                      "E: 0.001000 0002 0000 -0008\n"
                      "E: 0.001000 0002 0001 +07\n"
                      "E: 0.001000 0000 0000 0\n");
  EvemuReader reader({{"m", f}});
  const auto a = reader.next();
  const auto b = reader.next();
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->counts.x(), 10.0);
  EXPECT_EQ(a->counts.y(), -13.0);
  EXPECT_EQ(b->counts.x(), -8.0);
  EXPECT_EQ(b->counts.y(), 7.0);
  EXPECT_DOUBLE_EQ(b->t, 0.001);
  EXPECT_FALSE(reader.next());
}

TEST_F(EvemuFiles, GroupsBySynReportNotByTimestamp) {
  const auto f = file("g.events",
                      "E: 5.000100 0002 0000 3\n"
                      "E: 5.000200 0002 0000 4\n"
                      "E: 5.000250 0002 0001 -1\n"
                      "E: 5.000300 0000 0000 0\n"
                      "E: 5.000300 0002 0000 1\n"
                      "E: 5.000300 0000 0000 0\n");
  EvemuReader reader({{"m", f}});
  const auto a = reader.next();
  const auto b = reader.next();
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->counts.x(), 7.0);
  EXPECT_EQ(a->counts.y(), -1.0);
  EXPECT_DOUBLE_EQ(a->t, 0.0002);  // the SYN_REPORT at 5.000300, after the first event at 5.000100
  EXPECT_EQ(b->counts.x(), 1.0);
  EXPECT_DOUBLE_EQ(b->t, 0.0002);
  EXPECT_FALSE(reader.next());
}

TEST_F(EvemuFiles, FramesWithoutMotionGiveNoRow) {
  const auto f = file("k.events",
                      "E: 0.0 0001 0110 1\n"
                      "E: 0.0 0000 0000 0\n"
                      "E: 0.1 0002 0008 -1\n"
                      "E: 0.1 0000 0000 0\n"
                      "E: 0.2 0002 0000 0\n"
                      "E: 0.2 0000 0000 0\n"
                      "E: 0.3 0002 0001 2\n"
                      "E: 0.3 0000 0000 0\n");
  EvemuReader reader({{"m", f}});
  const auto row = reader.next();
  ASSERT_TRUE(row);
  EXPECT_DOUBLE_EQ(row->t, 0.3);
  EXPECT_EQ(row->counts.y(), 2.0);
  EXPECT_FALSE(reader.next());
  EXPECT_EQ(reader.stats(0).events_read, 8u);
}

TEST_F(EvemuFiles, FrameCutOffByTheEndOfTheFileIsKept) {
  const auto f = file("u.events",
                      "E: 1.0 0002 0000 5\n"
                      "E: 1.0 0000 0000 0\n"
                      "E: 1.5 0002 0000 -2\n"
                      "E: 1.6 0002 0001 9\n");
  EvemuReader reader({{"m", f}});
  const auto totals = read_all_rows(reader, 1);
  EXPECT_EQ(totals[0].rows, 2u);
  EXPECT_EQ(totals[0].dx, 3);
  EXPECT_EQ(totals[0].dy, 9);
  EXPECT_TRUE(reader.stats(0).unterminated);
}

TEST_F(EvemuFiles, CountsAfterSynDroppedAreKeptAndTheDropCounted) {
  const auto f = file("d.events",
                      "E: 1.0 0002 0000 5\n"
                      "E: 1.0 0000 0003 0\n"
                      "E: 1.1 0002 0000 2\n"
                      "E: 1.1 0000 0000 0\n");
  EvemuReader reader({{"m", f}});
  const auto totals = read_all_rows(reader, 1);
  EXPECT_EQ(totals[0].dx, 7);
  EXPECT_EQ(reader.stats(0).dropped, 1u);
}

TEST_F(EvemuFiles, NewStyleHeaderCommentsAndCrlfAreRead) {
  const auto f = file("n.evemu",
                      "# EVEMU 1.3\r\n"
                      "# Input device name: \"Test Mouse\"\r\n"
                      "N: Test Mouse\r\n"
                      "I: 0003 046d c077 0111\r\n"
                      "P: 00 00 00 00 00 00 00 00\r\n"
                      "B: 02 03 01 00 00 00 00 00 00\r\n"
                      "\r\n"
                      "################################\r\n"
                      "E: 0.000001 0002 0000 0004\t# EV_REL / REL_X 4\r\n"
                      "E: 0.000001 0000 0000 0000\t# ------------ SYN_REPORT (0) ----------\r\n");
  EvemuReader reader({{"m", f}});
  EXPECT_EQ(reader.stats(0).device, "Test Mouse");
  const auto row = reader.next();
  ASSERT_TRUE(row);
  EXPECT_EQ(row->counts.x(), 4.0);
  EXPECT_EQ(row->t, 0.0);
}

TEST_F(EvemuFiles, RecordingsAreMergedInTimeFromTheEarliestEvent) {
  const auto a = file("a.events",
                      "E: 100.000 0002 0000 1\nE: 100.010 0000 0000 0\n"
                      "E: 100.030 0002 0000 1\nE: 100.030 0000 0000 0\n");
  const auto b = file("b.events",
                      "E: 99.995 0001 0110 1\nE: 99.995 0000 0000 0\n"
                      "E: 100.020 0002 0001 2\nE: 100.020 0000 0000 0\n");
  EvemuReader reader({{"left", a}, {"right", b}});
  std::vector<std::pair<int, double>> order;
  while (const auto row = reader.next()) order.emplace_back(row->sensor, row->t);
  ASSERT_EQ(order.size(), 3u);
  // The earliest event of all is b's button at 99.995 s: t = 0 there.
  EXPECT_EQ(order[0].first, 0);
  EXPECT_NEAR(order[0].second, 0.015, 1e-12);
  EXPECT_EQ(order[1].first, 1);
  EXPECT_NEAR(order[1].second, 0.025, 1e-12);
  EXPECT_EQ(order[2].first, 0);
  EXPECT_NEAR(order[2].second, 0.035, 1e-12);
}

// ---------------------------------------------------------------- errors

struct BadCase {
  const char* name;
  const char* text;
  const char* error;  // after "FILE:"
};

class MalformedEvemu : public ::testing::TestWithParam<BadCase> {};

TEST_P(MalformedEvemu, IsRejectedWithFileLineAndWhat) {
  const auto dir = test::scratch_dir("evemu-bad");
  const auto f = write_file(dir / "bad.events", GetParam().text);
  const std::string message = error_of([&] {
    EvemuReader reader({{"m", f}});
    while (reader.next()) {
    }
  });
  EXPECT_EQ(message, f.string() + ":" + GetParam().error);
  fs::remove_all(dir);
}

constexpr const char* kGood = "E: 0.000001 0002 0000 1\nE: 0.000001 0000 0000 0\n";

INSTANTIATE_TEST_SUITE_P(
    Cases, MalformedEvemu,
    ::testing::Values(
        BadCase{"NotEvemu", "# EVEMU 1.2\nhello world\n", "2: not an evemu line: 'hello world'"},
        BadCase{"LowerCaseTag", "e: 0.1 0002 0000 1\n",
                "1: not an evemu line: 'e: 0.1 0002 0000 1'"},
        BadCase{"MissingValue", "E: 0.000001 0002 0000\n",
                "1: event line has 3 of its 4 fields (time, type, code, value)"},
        BadCase{"CommentEatsValue", "E: 0.000001 0002 0000 # 1\n",
                "1: event line has 3 of its 4 fields (time, type, code, value)"},
        BadCase{"TrailingText", "E: 0.000001 0002 0000 1 junk\n",
                "1: unexpected 'junk' after the event value"},
        BadCase{"TimeNotANumber", "E: abc 0002 0000 1\n",
                "1: event time 'abc' is not SECONDS.FRACTION (at most 9 fraction digits)"},
        BadCase{"TimeWithoutFraction", "E: 12 0002 0000 1\n",
                "1: event time '12' is not SECONDS.FRACTION (at most 9 fraction digits)"},
        BadCase{"TimeEmptyFraction", "E: 12. 0002 0000 1\n",
                "1: event time '12.' is not SECONDS.FRACTION (at most 9 fraction digits)"},
        BadCase{"TimeNegative", "E: -1.5 0002 0000 1\n",
                "1: event time '-1.5' is not SECONDS.FRACTION (at most 9 fraction digits)"},
        BadCase{"TimeTooFine", "E: 1.1234567890 0002 0000 1\n",
                "1: event time '1.1234567890' is not SECONDS.FRACTION (at most 9 fraction "
                "digits)"},
        BadCase{"TypeWithPrefix", "E: 0.1 0x02 0000 1\n",
                "1: event type '0x02' is not 1-4 hex digits"},
        BadCase{"TypeTooLong", "E: 0.1 00002 0000 1\n",
                "1: event type '00002' is not 1-4 hex digits"},
        BadCase{"CodeNotHex", "E: 0.1 0002 00g0 1\n", "1: event code '00g0' is not 1-4 hex digits"},
        BadCase{"ValueHex", "E: 0.1 0002 0000 0x10\n",
                "1: event value '0x10' is not a base-10 integer"},
        BadCase{"ValueFloat", "E: 0.1 0002 0000 1.5\n",
                "1: event value '1.5' is not a base-10 integer"},
        BadCase{"ValueSignOnly", "E: 0.1 0002 0000 -\n",
                "1: event value '-' is not a base-10 integer"},
        BadCase{"ValueTooLarge", "E: 0.1 0002 0000 2147483648\n",
                "1: event value '2147483648' is outside the 32-bit range"},
        BadCase{"ValueTooSmall", "E: 0.1 0002 0000 -99999999999999999999\n",
                "1: event value '-99999999999999999999' is outside the 32-bit range"},
        BadCase{"TimeBackwards", "E: 0.000002 0002 0000 1\nE: 0.000001 0000 0000 0\n",
                "2: event time 0.000001 is before the previous event's 0.000002"},
        BadCase{"BadLineAfterEvents", "E: 0.000001 0002 0000 1\nE: 0.000001 0000 0000 0\n!\n",
                "3: not an evemu line: '!'"},
        BadCase{"NoEvents", "# EVEMU 1.2\nN: Mouse\n", " no events"},
        BadCase{"Empty", "", " no events"}),
    [](const ::testing::TestParamInfo<BadCase>& p) { return std::string(p.param.name); });

TEST(EvemuReader, ExtremeValuesAreAccepted) {
  const auto dir = test::scratch_dir("evemu-extreme");
  const auto f = write_file(dir / "x.events",
                            "E: 0.1 2 0 -2147483648\nE: 0.1 0 0 0\n"
                            "E: 0.2 0002 0001 2147483647\nE: 0.2 0 0 0\n");
  EvemuReader reader({{"m", f}});
  const auto totals = read_all_rows(reader, 1);
  EXPECT_EQ(totals[0].dx, -2147483648LL);
  EXPECT_EQ(totals[0].dy, 2147483647LL);
  fs::remove_all(dir);
}

TEST(EvemuReader, MissingFileIsNamed) {
  const fs::path f = "/nonexistent/moa/x.events";
  EXPECT_EQ(error_of([&] { EvemuReader reader({{"m", f}}); }), f.string() + ": cannot open");
}

TEST(EvemuReader, DescriptionWithoutEventsFileIsNamed) {
  const auto dir = test::scratch_dir("evemu-desc");
  const auto desc = write_file(dir / "m.desc", "N: Mouse\n");
  EXPECT_EQ(error_of([&] {
              EvemuReader reader({{"m", desc}});
            }),
            desc.string() + ": no events file '" + (dir / "m.events").string() +
                "' beside this description");
  fs::remove_all(dir);
}

TEST(EvemuReader, MalformedDescriptionIsRejectedAtItsLine) {
  const auto dir = test::scratch_dir("evemu-desc");
  write_file(dir / "m.events", kGood);
  const auto desc = write_file(dir / "m.desc", "# EVEMU 1.2\nN: Mouse\nI: 0011 0002\n%%%\n");
  EXPECT_EQ(error_of([&] {
              EvemuReader reader({{"m", dir / "m.events"}});
            }),
            desc.string() + ":4: not an evemu line: '%%%'");
  write_file(dir / "m.desc", "N: Mouse\nE: 0.1 0002 0000 1\n");
  EXPECT_EQ(
      error_of([&] {
        EvemuReader reader({{"m", dir / "m.events"}});
      }),
      desc.string() + ":2: event line in a device description (events belong in the .events file)");
  fs::remove_all(dir);
}

TEST(EvemuReader, OldStyleEventsWithoutDescriptionAreRead) {
  const auto dir = test::scratch_dir("evemu-nodesc");
  const auto f = write_file(dir / "m.events", kGood);
  EvemuReader reader({{"m", f}});
  EXPECT_EQ(read_all_rows(reader, 1)[0].dx, 1);
  EXPECT_EQ(reader.stats(0).device, "");
  fs::remove_all(dir);
}

// ------------------------------------------------------ moa import-evemu

// mice.csv by a plain scan: per sensor, rows and sums; times in order.
struct MiceScan {
  std::map<std::string, Totals> sensors;
  std::map<std::string, double> first;  // time of each sensor's first row
  std::vector<double> times;
  std::string header;
};

MiceScan scan_mice(const fs::path& file) {
  std::ifstream in(file);
  MiceScan s;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (s.header.empty()) {
      s.header = line;
      continue;
    }
    std::istringstream fields(line);
    std::string t, name, dx, dy;
    std::getline(fields, t, ',');
    std::getline(fields, name, ',');
    std::getline(fields, dx, ',');
    std::getline(fields, dy, ',');
    auto& totals = s.sensors[name];
    totals.dx += std::stoll(dx);
    totals.dy += std::stoll(dy);
    ++totals.rows;
    s.times.push_back(std::stod(t));
    s.first.emplace(name, s.times.back());
  }
  return s;
}

TEST(ImportEvemu, WritesALogThatKeepsEveryCountOfEveryRecording) {
  const auto dir = test::scratch_dir("import-evemu");
  const auto ps2 = kData / "ps2-generic-mouse.events";
  const auto thin = kData / "ultrathin-touch-mouse.events";
  const auto r = test::run_moa("import-evemu --sensor ps2=" + ps2.string() +
                               " --sensor thin=" + thin.string() + " --out " + dir.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const MiceScan mice = scan_mice(dir / "mice.csv");
  EXPECT_EQ(mice.header, "t,sensor,dx,dy");
  ASSERT_EQ(mice.sensors.size(), 2u);
  for (const auto& [name, file] : {std::pair{"ps2", ps2}, std::pair{"thin", thin}}) {
    const Scan expected = scan(file);
    const Totals& got = mice.sensors.at(name);
    EXPECT_EQ(got.dx, expected.sum_x) << name;
    EXPECT_EQ(got.dy, expected.sum_y) << name;
    EXPECT_EQ(got.rows, expected.motion_frames) << name;
  }
  EXPECT_TRUE(std::is_sorted(mice.times.begin(), mice.times.end()));
  // The new-style recording's clock starts at 0, the old one's in 2012: the
  // earliest event over both is the ultrathin's first, at t = 0.
  EXPECT_EQ(mice.times.front(), 0.0);
  EXPECT_EQ(mice.first.at("thin"), 0.0);
  // The ps2's first frame ends at its SYN_REPORT, 1329846856.201621 s.
  EXPECT_EQ(mice.first.at("ps2"), 1329846856.201621);
  // Recordings made decades apart: said, as `moa odometry` would refuse the gap.
  EXPECT_THAT(r.err, HasSubstr("warning: ps2 starts"));
  EXPECT_THAT(r.err, HasSubstr("after thin ends"));
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  fs::remove_all(dir);
}

TEST(ImportEvemu, OneOldStyleRecordingStartsAtZero) {
  const auto dir = test::scratch_dir("import-evemu");
  const auto r =
      test::run_moa("import-evemu --sensor m1=" + (kData / "ps2-generic-mouse.events").string() +
                    " --out " + dir.string() + " --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "");
  const MiceScan mice = scan_mice(dir / "mice.csv");
  EXPECT_DOUBLE_EQ(mice.times.front(), 8e-6);
  EXPECT_LT(mice.times.back(), 3600.0);
  EXPECT_EQ(mice.sensors.at("m1").dx, -5424);
  fs::remove_all(dir);
}

TEST(ImportEvemu, MalformedRecordingFailsWithFileLineAndWritesNothing) {
  const auto dir = test::scratch_dir("import-evemu-bad");
  const auto bad = write_file(dir / "bad.events", std::string(kGood) + "E: 0.2 0002 0000 x\n");
  const auto r =
      test::run_moa("import-evemu --sensor m=" + bad.string() + " --out " + (dir / "log").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "moa import-evemu: error: " + bad.string() +
                       ":3: event value 'x' is not a base-10 integer\n");
  EXPECT_FALSE(fs::exists(dir / "log" / "mice.csv"));
  if (fs::exists(dir / "log")) {
    EXPECT_TRUE(fs::is_empty(dir / "log"));
  }
  fs::remove_all(dir);
}

TEST(ImportEvemu, BadSensorArgumentsAreRejected) {
  const auto events = (kData / "ps2-generic-mouse.events").string();
  const auto dir = test::scratch_dir("import-evemu-args");
  const std::string out = " --out " + dir.string();
  auto r = test::run_moa("import-evemu --sensor " + events + out);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "moa import-evemu: error: --sensor " + events + ": expected NAME=PATH\n");
  r = test::run_moa("import-evemu --sensor a=" + events + " --sensor a=" + events + out);
  EXPECT_EQ(r.err, "moa import-evemu: error: --sensor: sensor 'a' given twice\n");
  r = test::run_moa("import-evemu --sensor =" + events + out);
  EXPECT_EQ(r.err, "moa import-evemu: error: --sensor =" + events +
                       ": expected NAME=PATH, both non-empty\n");
  r = test::run_moa("import-evemu --sensor 'a,b=" + events + "'" + out);
  EXPECT_EQ(r.err,
            "moa import-evemu: error: --sensor a,b=" + events +
                ": invalid sensor name 'a,b': a name is 1 to 32 characters among A-Z a-z 0-9 _ . - "
                "(what mice.csv, odometry.csv and JSON all carry)\n");
  EXPECT_TRUE(fs::is_empty(dir));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace moa::io
