// Log format v1 (docs/formats/log.md): the CSV readers, every rejection with
// its exact "FILE:LINE: what" message, and the all-or-nothing writers.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "moa/formats/atomic_file.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/csv.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/log.hpp"
#include "support/error_of.hpp"

namespace moa::io {
namespace {

using test::error_of;

// A fresh directory, removed with everything in it at the end of the test.
class TempDir {
 public:
  TempDir() {
    std::random_device random;
    path_ = std::filesystem::temp_directory_path() /
            ("moa-test-log-" + std::to_string(random()) + std::to_string(random()));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

  /// Writes `text` (byte for byte) to a file in the directory; returns its path.
  std::filesystem::path write(const std::string& name, const std::string& text) const {
    const auto file = path_ / name;
    std::ofstream(file, std::ios::binary) << text;
    return file;
  }
  std::size_t entries() const {
    return static_cast<std::size_t>(std::distance(std::filesystem::directory_iterator(path_),
                                                  std::filesystem::directory_iterator()));
  }

 private:
  std::filesystem::path path_;
};

std::string read_text(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

RobotConfig three_mice() {
  return parse_config(
      "version: 1\n"
      "sensors:\n"
      "  - {name: m1, position: [0.1, 0], yaw: 0, cpi: 800}\n"
      "  - {name: m2, position: [0, 0.1], yaw: 0, cpi: 800}\n"
      "  - {name: m3, position: [-0.1, 0], yaw: 0, cpi: 800}\n",
      "robot.yaml");
}

std::vector<SensorRow> read_mice(const std::filesystem::path& path) {
  MiceReader reader(path, three_mice());
  std::vector<SensorRow> rows;
  while (auto row = reader.next()) rows.push_back(*row);
  return rows;
}

// The error of reading all of mice.csv with `text` in a fresh log directory,
// with the file's path replaced by "mice.csv" for short expectations.
std::string mice_error(const std::string& text) {
  const TempDir dir;
  const auto file = dir.write("mice.csv", text);
  std::string message = error_of([&] { read_mice(file); });
  if (message.starts_with(file.string())) message.replace(0, file.string().size(), "mice.csv");
  return message;
}

template <class Row>
std::string rows_error(const std::string& text) {
  const TempDir dir;
  const auto file = dir.write("rows.csv", text);
  std::string message = error_of([&] { read_all<Row>(file); });
  if (message.starts_with(file.string())) message.replace(0, file.string().size(), "rows.csv");
  return message;
}

// ------------------------------------------------------------- mice.csv: rows

TEST(LogMice, ParsesEveryColumn) {
  const TempDir dir;
  dir.write("mice.csv",
            "t,sensor,dx,dy,squal,flags\n"
            "0.01,m1,3,-4,120,0\n"
            "0.01,m3,0,7,255,3\n"
            "0.02,m2,-12,0,0,1\n");
  const auto rows = read_mice(dir.path());
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0].t, 0.01);
  EXPECT_EQ(rows[0].sensor, 0);
  EXPECT_EQ(rows[0].counts, Eigen::Vector2d(3, -4));
  EXPECT_EQ(rows[0].squal, 120);
  EXPECT_EQ(rows[0].flags, 0);
  EXPECT_EQ(rows[1].sensor, 2);
  EXPECT_EQ(rows[1].squal, 255);
  EXPECT_EQ(rows[1].flags, kFlagOverflow | kFlagLift);
  EXPECT_EQ(rows[2].t, 0.02);
  EXPECT_EQ(rows[2].sensor, 1);
  EXPECT_EQ(rows[2].counts, Eigen::Vector2d(-12, 0));
  EXPECT_EQ(rows[2].squal, 0);
  EXPECT_EQ(rows[2].flags, kFlagOverflow);
}

TEST(LogMice, AcceptsTheFileOrTheLogDirectory) {
  const TempDir dir;
  const auto file = dir.write("mice.csv", "t,sensor,dx,dy\n0,m1,1,2\n");
  EXPECT_EQ(read_mice(file).size(), 1u);
  EXPECT_EQ(read_mice(dir.path()).size(), 1u);
}

TEST(LogMice, StartTimeIsTheFirstRowsTimeAndLosesNoRow) {
  const TempDir dir;
  dir.write("mice.csv", "t,sensor,dx,dy\n5.25,m1,1,2\n5.5,m2,3,4\n");
  MiceReader reader(dir.path(), three_mice());
  EXPECT_EQ(reader.start_time(), 5.25);
  EXPECT_EQ(reader.start_time(), 5.25);
  auto first = reader.next();
  ASSERT_TRUE(first);
  EXPECT_EQ(first->t, 5.25);
  EXPECT_EQ(first->counts, Eigen::Vector2d(1, 2));
  auto second = reader.next();
  ASSERT_TRUE(second);
  EXPECT_EQ(second->t, 5.5);
  EXPECT_EQ(reader.start_time(), 5.25);
  EXPECT_FALSE(reader.next());
}

TEST(LogMice, StartTimeAfterReadingIsStillTheFirstRowsTime) {
  const TempDir dir;
  dir.write("mice.csv", "t,sensor,dx,dy\n1,m1,1,2\n2,m2,3,4\n");
  MiceReader reader(dir.path(), three_mice());
  ASSERT_TRUE(reader.next());
  ASSERT_TRUE(reader.next());
  EXPECT_EQ(reader.start_time(), 1.0);
}

TEST(LogMice, HeaderOnlyFileHasNoRowsAndNoStartTime) {
  const TempDir dir;
  const auto file = dir.write("mice.csv", "t,sensor,dx,dy\n");
  MiceReader reader(file, three_mice());
  EXPECT_FALSE(reader.next());
  MiceReader again(file, three_mice());
  EXPECT_EQ(error_of([&] { again.start_time(); }), file.string() + ": no data rows");
}

TEST(LogMice, CommentsAreSkippedAnywhere) {
  const auto rows = [] {
    const TempDir dir;
    dir.write("mice.csv",
              "# recorded by hand\n"
              "#t,this,is,not,the,header\n"
              "t,sensor,dx,dy\n"
              "# first row next\n"
              "0,m1,1,1\n"
              "#0,m9,x,y\n"
              "1,m2,2,2\n"
              "# the end\n");
    return read_mice(dir.path());
  }();
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[1].sensor, 1);
}

TEST(LogMice, ColumnOrderIsFreeAndExtraColumnsAreIgnored) {
  const TempDir dir;
  dir.write("mice.csv",
            "note,dy,flags,sensor,t,dx,raw\n"
            "hello,-2,2,m3,0.5,7,x y z\n");
  const auto rows = read_mice(dir.path());
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].t, 0.5);
  EXPECT_EQ(rows[0].sensor, 2);
  EXPECT_EQ(rows[0].counts, Eigen::Vector2d(7, -2));
  EXPECT_EQ(rows[0].flags, kFlagLift);
  EXPECT_FALSE(rows[0].squal);
}

TEST(LogMice, OptionalColumnsMayBeAbsentOrEmpty) {
  const TempDir dir;
  dir.write("mice.csv", "t,sensor,dx,dy,squal,flags\n0,m1,1,1,,\n0,m2,1,1,40,\n");
  const auto rows = read_mice(dir.path());
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_FALSE(rows[0].squal);
  EXPECT_EQ(rows[0].flags, 0);
  EXPECT_EQ(rows[1].squal, 40);
}

TEST(LogMice, CrlfLineEndingsAndSpacesAroundFieldsAreAccepted) {
  const TempDir dir;
  dir.write("mice.csv", "t, sensor, dx, dy\r\n0.25, m2, 3 , +4\r\n");
  const auto rows = read_mice(dir.path());
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].t, 0.25);
  EXPECT_EQ(rows[0].sensor, 1);
  EXPECT_EQ(rows[0].counts, Eigen::Vector2d(3, 4));
}

TEST(LogMice, LastLineWithoutNewlineIsRead) {
  const TempDir dir;
  dir.write("mice.csv", "t,sensor,dx,dy\n0,m1,1,1\n1,m1,2,2");
  EXPECT_EQ(read_mice(dir.path()).size(), 2u);
}

TEST(LogMice, TrailingBlankLinesAreAccepted) {
  const TempDir dir;
  dir.write("mice.csv", "t,sensor,dx,dy\n0,m1,1,1\n\n\r\n");
  EXPECT_EQ(read_mice(dir.path()).size(), 1u);
}

TEST(LogMice, EqualTimesAreAccepted) {
  const TempDir dir;
  dir.write("mice.csv", "t,sensor,dx,dy\n1,m1,1,1\n1,m2,1,1\n1,m1,0,0\n");
  EXPECT_EQ(read_mice(dir.path()).size(), 3u);
}

TEST(LogMice, RowsAreStreamedNotLoaded) {
  // A reader holds one row: rows appended after it was opened are still seen.
  const TempDir dir;
  const auto file = dir.write("mice.csv", "t,sensor,dx,dy\n0,m1,1,1\n");
  MiceReader reader(file, three_mice());
  ASSERT_TRUE(reader.next());
  std::ofstream(file, std::ios::app) << "1,m2,2,2\n";
  const auto row = reader.next();
  ASSERT_TRUE(row);
  EXPECT_EQ(row->sensor, 1);
}

// ------------------------------------------------------ mice.csv: rejections

TEST(LogMiceErrors, MissingFileCannotBeOpened) {
  const TempDir dir;
  EXPECT_EQ(error_of([&] { MiceReader(dir.path(), three_mice()); }),
            (dir.path() / "mice.csv").string() + ": cannot open");
}

TEST(LogMiceErrors, EmptyFileIsRejected) {
  EXPECT_EQ(mice_error(""), "mice.csv:1: no header row (the file is empty)");
  EXPECT_EQ(mice_error("# only a comment\n"), "mice.csv:2: no header row (the file is empty)");
}

TEST(LogMiceErrors, UnknownSensorNameIsRejectedWithLine) {
  EXPECT_EQ(mice_error("t,sensor,dx,dy\n"
                       "# m9 is not in the config\n"
                       "0,m1,0,0\n"
                       "0,m2,0,0\n"
                       "0,m3,0,0\n"
                       "0.1,m1,0,0\n"
                       "0.1,m9,0,0\n"),
            "mice.csv:7: unknown sensor 'm9' (the config's sensors: m1, m2, m3)");
}

TEST(LogMiceErrors, TimeGoingBackwardsIsRejectedWithLine) {
  EXPECT_EQ(mice_error("t,sensor,dx,dy\n0.6,m1,0,0\n0.5,m2,0,0\n"),
            "mice.csv:3: time goes backwards (0.5 after 0.6)");
}

TEST(LogMiceErrors, MissingColumnIsRejectedAtTheHeader) {
  EXPECT_EQ(mice_error("t,sensor,dx\n0,m1,1\n"), "mice.csv:1: missing column 'dy'");
  EXPECT_EQ(mice_error("# comment\ntime,sensor,dx,dy\n"), "mice.csv:2: missing column 't'");
  EXPECT_EQ(mice_error("t,dx,dy\n"), "mice.csv:1: missing column 'sensor'");
}

TEST(LogMiceErrors, DuplicateColumnIsRejected) {
  EXPECT_EQ(mice_error("t,sensor,dx,dy,dx\n"), "mice.csv:1: duplicate column 'dx'");
}

TEST(LogMiceErrors, UnnamedColumnIsRejected) {
  EXPECT_EQ(mice_error("t,sensor,,dx,dy\n"), "mice.csv:1: column 3 of the header has no name");
}

TEST(LogMiceErrors, WrongNumberOfFieldsIsRejected) {
  EXPECT_EQ(mice_error("t,sensor,dx,dy,squal\n0,m1,1,1,9\n0,m1,1,1\n"),
            "mice.csv:3: expected 5 fields, found 4");
  EXPECT_EQ(mice_error("t,sensor,dx,dy\n0,m1,1,1,\n"), "mice.csv:2: expected 4 fields, found 5");
}

TEST(LogMiceErrors, NonIntegerCountIsRejected) {
  const std::string header = "t,sensor,dx,dy\n0,m1,1,1\n";
  EXPECT_EQ(mice_error(header + "0,m1,abc,1\n"),
            "mice.csv:3: column 'dx': 'abc' is not an integer");
  EXPECT_EQ(mice_error(header + "0,m1,1,1.5\n"),
            "mice.csv:3: column 'dy': '1.5' is not an integer");
  EXPECT_EQ(mice_error(header + "0,m1,1e3,1\n"),
            "mice.csv:3: column 'dx': '1e3' is not an integer");
  EXPECT_EQ(mice_error(header + "0,m1,0x10,1\n"),
            "mice.csv:3: column 'dx': '0x10' is not an integer");
}

TEST(LogMiceErrors, EmptyRequiredFieldIsRejected) {
  EXPECT_EQ(mice_error("t,sensor,dx,dy\n0,m1,,1\n"), "mice.csv:2: column 'dx': empty field");
  EXPECT_EQ(mice_error("t,sensor,dx,dy\n,m1,1,1\n"), "mice.csv:2: column 't': empty field");
}

TEST(LogMiceErrors, CountBeyondExactDoublesIsRejected) {
  EXPECT_EQ(mice_error("t,sensor,dx,dy\n0,m1,9007199254740993,1\n"),
            "mice.csv:2: column 'dx': 9007199254740993 is outside "
            "-9007199254740992..9007199254740992");
}

TEST(LogMiceErrors, SqualOutside0To255IsRejected) {
  EXPECT_EQ(mice_error("t,sensor,dx,dy,squal\n0,m1,1,1,256\n"),
            "mice.csv:2: column 'squal': 256 is outside 0..255");
  EXPECT_EQ(mice_error("t,sensor,dx,dy,squal\n0,m1,1,1,-1\n"),
            "mice.csv:2: column 'squal': -1 is outside 0..255");
  EXPECT_EQ(mice_error("t,sensor,dx,dy,squal\n0,m1,1,1,12.5\n"),
            "mice.csv:2: column 'squal': '12.5' is not an integer");
}

TEST(LogMiceErrors, NegativeOrNonIntegerFlagsAreRejected) {
  EXPECT_EQ(mice_error("t,sensor,dx,dy,flags\n0,m1,1,1,-1\n"),
            "mice.csv:2: column 'flags': -1 is outside 0..255");
  EXPECT_EQ(mice_error("t,sensor,dx,dy,flags\n0,m1,1,1,lift\n"),
            "mice.csv:2: column 'flags': 'lift' is not an integer");
}

TEST(LogMiceErrors, TimeThatIsNotANumberIsRejected) {
  EXPECT_EQ(mice_error("t,sensor,dx,dy\n0.1s,m1,1,1\n"),
            "mice.csv:2: column 't': '0.1s' is not a number");
}

TEST(LogMiceErrors, NonFiniteTimeIsRejected) {
  EXPECT_EQ(mice_error("t,sensor,dx,dy\nnan,m1,1,1\n"),
            "mice.csv:2: column 't': 'nan' is not a finite number");
  EXPECT_EQ(mice_error("t,sensor,dx,dy\n0,m1,1,1\ninf,m1,1,1\n"),
            "mice.csv:3: column 't': 'inf' is not a finite number");
  EXPECT_EQ(mice_error("t,sensor,dx,dy\n1e999,m1,1,1\n"),
            "mice.csv:2: column 't': '1e999' is out of range");
}

TEST(LogMiceErrors, BlankLineInTheMiddleIsRejectedWithItsLine) {
  EXPECT_EQ(mice_error("t,sensor,dx,dy\n0,m1,1,1\n\n1,m1,1,1\n"),
            "mice.csv:3: blank line (only allowed at the end of the file)");
  EXPECT_EQ(mice_error("t,sensor,dx,dy\n0,m1,1,1\n\n# a comment is content too\n"),
            "mice.csv:3: blank line (only allowed at the end of the file)");
  EXPECT_EQ(mice_error("\nt,sensor,dx,dy\n"),
            "mice.csv:1: blank line (only allowed at the end of the file)");
}

TEST(LogMiceErrors, ControlCharactersInMessagesAreEscaped) {
  EXPECT_EQ(mice_error("t,sensor,dx,dy\n0,m\x01\r9,1,1\n"),
            "mice.csv:2: unknown sensor 'm\\x01\\x0d9' (the config's sensors: m1, m2, m3)");
}

// Bytes that are not well-formed UTF-8 are escaped too, so that a message
// is valid UTF-8 whatever the input held; valid characters stay as they are
// (issue #47, item 10: errors echoed invalid UTF-8 raw).
TEST(LogMiceErrors, InvalidUtf8InMessagesIsEscapedAndValidUtf8Kept) {
  EXPECT_EQ(mice_error("t,sensor,dx,dy\n0,m\xff\xc3\xa9,1,1\n"),
            "mice.csv:2: unknown sensor 'm\\xff\xc3\xa9' (the config's sensors: m1, m2, m3)");
  // A stray continuation byte, an overlong form, a surrogate, beyond
  // U+10FFFF, a sequence cut short; then a 3- and a 4-byte character.
  EXPECT_EQ(io::printable("\x80|\xc0\xaf|\xed\xa0\x80|\xf4\x90\x80\x80|\xe2\x82"),
            "\\x80|\\xc0\\xaf|\\xed\\xa0\\x80|\\xf4\\x90\\x80\\x80|\\xe2\\x82");
  EXPECT_EQ(io::printable("\xe2\x82\xac \xf0\x9f\x90\xad"), "\xe2\x82\xac \xf0\x9f\x90\xad");
}

// ------------------------------------------------ wheels, camera and truth

TEST(LogRows, WheelsAreParsed) {
  const TempDir dir;
  const auto file = dir.write("wheels.csv", "t,vx,vy,omega\n0.1,0.2,-0.05,1.5\n0.2,0,0,0\n");
  const auto rows = read_all<WheelRow>(file);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].t, 0.1);
  EXPECT_EQ(rows[0].twist.v, Eigen::Vector2d(0.2, -0.05));
  EXPECT_EQ(rows[0].twist.omega, 1.5);
  EXPECT_EQ(rows[1].t, 0.2);
}

TEST(LogRows, TruthIsParsed) {
  const TempDir dir;
  const auto file = dir.write("truth.csv", "theta,y,x,t\n0.5,2,1,3\n");
  TruthReader reader(file);
  const auto row = reader.next();
  ASSERT_TRUE(row);
  EXPECT_EQ(row->t, 3.0);
  EXPECT_EQ(row->pose.t, Eigen::Vector2d(1, 2));
  EXPECT_EQ(row->pose.theta, 0.5);
  EXPECT_FALSE(reader.next());
}

TEST(LogRows, CameraOptionalColumnsAreReadWhenGiven) {
  const TempDir dir;
  const auto file = dir.write("camera.csv",
                              "t,x,y,theta,sx,sy\n"
                              "1,0.5,0.25,0.1,0.01,0.02\n"
                              "2,0.6,0.35,,,\n");
  const auto rows = read_all<CameraRow>(file);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].position, Eigen::Vector2d(0.5, 0.25));
  EXPECT_EQ(rows[0].theta, 0.1);
  ASSERT_TRUE(rows[0].sigma);
  EXPECT_EQ(*rows[0].sigma, Eigen::Vector2d(0.01, 0.02));
  EXPECT_FALSE(rows[1].theta);
  EXPECT_FALSE(rows[1].sigma);
}

TEST(LogRows, CameraWithoutOptionalColumns) {
  const TempDir dir;
  const auto rows = read_all<CameraRow>(dir.write("camera.csv", "t,x,y\n1,2,3\n"));
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_FALSE(rows[0].theta);
  EXPECT_FALSE(rows[0].sigma);
}

TEST(LogRowsErrors, MissingColumnIsRejected) {
  EXPECT_EQ(rows_error<WheelRow>("t,vx,omega\n"), "rows.csv:1: missing column 'vy'");
  EXPECT_EQ(rows_error<TruthRow>("t,x,y\n"), "rows.csv:1: missing column 'theta'");
  EXPECT_EQ(rows_error<CameraRow>("x,y\n"), "rows.csv:1: missing column 't'");
}

TEST(LogRowsErrors, OneStandardDeviationWithoutTheOtherIsRejected) {
  EXPECT_EQ(rows_error<CameraRow>("t,x,y,sx\n"), "rows.csv:1: missing column 'sy'");
  EXPECT_EQ(rows_error<CameraRow>("t,x,y,sy\n"), "rows.csv:1: missing column 'sx'");
  EXPECT_EQ(rows_error<CameraRow>("t,x,y,sx,sy\n0,0,0,0.1,\n"),
            "rows.csv:2: columns 'sx' and 'sy' must be both given or both empty");
}

TEST(LogRowsErrors, NonPositiveStandardDeviationIsRejected) {
  EXPECT_EQ(rows_error<CameraRow>("t,x,y,sx,sy\n0,0,0,0.1,0\n"),
            "rows.csv:2: column 'sy': must be > 0 (found 0)");
}

TEST(LogRowsErrors, NonFiniteValueIsRejected) {
  EXPECT_EQ(rows_error<WheelRow>("t,vx,vy,omega\n0,0,0,0\n1,0,-inf,0\n"),
            "rows.csv:3: column 'vy': '-inf' is not a finite number");
  EXPECT_EQ(rows_error<CameraRow>("t,x,y,theta\n0,0,0,NaN\n"),
            "rows.csv:2: column 'theta': 'NaN' is not a finite number");
}

TEST(LogRowsErrors, TimeGoingBackwardsIsRejected) {
  EXPECT_EQ(rows_error<TruthRow>("t,x,y,theta\n2,0,0,0\n2,0,0,0\n1.5,0,0,0\n"),
            "rows.csv:4: time goes backwards (1.5 after 2)");
}

TEST(LogRowsErrors, WrongNumberOfFieldsIsRejected) {
  EXPECT_EQ(rows_error<WheelRow>("t,vx,vy,omega\n0,0,0\n"),
            "rows.csv:2: expected 4 fields, found 3");
}

TEST(LogRowsErrors, MissingFileCannotBeOpened) {
  const TempDir dir;
  EXPECT_EQ(error_of([&] { WheelsReader reader(dir / "wheels.csv"); }),
            (dir / "wheels.csv").string() + ": cannot open");
  EXPECT_EQ(error_of([&] { WheelsReader reader(dir.path()); }),
            dir.path().string() + ": cannot open (is a directory)");
}

// ---------------------------------------------------------- odometry.csv

TEST(OdometryWriter, NoFileExistsBeforeCommit) {
  const TempDir dir;
  const auto file = dir / "odometry.csv";
  OdometryWriter writer(file);
  writer.write(0.0, Pose2{}, Twist2{});
  EXPECT_FALSE(std::filesystem::exists(file));
  // Nor any other: the temporary has no name (a killed run leaves none).
  EXPECT_EQ(dir.entries(), 0u);
  writer.commit();
  EXPECT_TRUE(std::filesystem::exists(file));
  EXPECT_EQ(dir.entries(), 1u);
}

TEST(OdometryWriter, CommittedFileHoldsHeaderAndEveryRow) {
  const TempDir dir;
  const auto file = dir / "odometry.csv";
  {
    OdometryWriter writer(file, {"source", "used"});
    writer.write(0.0, Pose2{{0.0, 0.0}, 0.0}, Twist2{{0.0, 0.0}, 0.0}, {"mice", "7"});
    writer.write(0.01, Pose2{{1.5, -2.25}, 7.0}, Twist2{{0.125, -1e-9}, 2.5}, {"wheels", "0"});
    writer.commit();
  }
  EXPECT_EQ(read_text(file),
            "t,x,y,theta,vx,vy,omega,source,used\n"
            "0,0,0,0,0,0,0,mice,7\n"
            "0.01,1.5,-2.25,7,0.125,-1e-09,2.5,wheels,0\n");
}

TEST(OdometryWriter, NumbersReadBackExactly) {
  const TempDir dir;
  const auto file = dir / "odometry.csv";
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> value(-100.0, 100.0);
  std::vector<TruthRow> written;
  {
    OdometryWriter writer(file);
    double t = 1.7e9;  // a Unix time: microseconds must survive
    for (int i = 0; i < 100; ++i) {
      t += 1e-6 * (1.0 + static_cast<double>(rng() % 10000));
      const Pose2 pose{{value(rng), value(rng) * 1e-7}, value(rng)};
      writer.write(t, pose, Twist2{{value(rng), value(rng)}, value(rng)});
      written.push_back({t, pose});
    }
    writer.commit();
  }
  const auto read = read_all<TruthRow>(file);  // odometry.csv has the truth columns
  ASSERT_EQ(read.size(), written.size());
  for (std::size_t i = 0; i < read.size(); ++i) {
    EXPECT_EQ(read[i].t, written[i].t);
    EXPECT_EQ(read[i].pose.t, written[i].pose.t);
    EXPECT_EQ(read[i].pose.theta, written[i].pose.theta);
  }
}

TEST(OdometryWriter, ExceptionMidwayLeavesNoFile) {
  const TempDir dir;
  const auto file = dir / "odometry.csv";
  try {
    OdometryWriter writer(file);
    writer.write(0.0, Pose2{}, Twist2{});
    throw std::runtime_error("estimator failed");
  } catch (const std::runtime_error&) {
  }
  EXPECT_FALSE(std::filesystem::exists(file));
  EXPECT_EQ(dir.entries(), 0u);
}

TEST(OdometryWriter, AbortedRunKeepsThePreviousFile) {
  const TempDir dir;
  const auto file = dir.write("odometry.csv", "previous\n");
  { OdometryWriter writer(file); }
  EXPECT_EQ(read_text(file), "previous\n");
}

TEST(OdometryWriter, WrongNumberOfExtraValuesIsRejected) {
  const TempDir dir;
  const auto file = dir / "odometry.csv";
  OdometryWriter writer(file, {"source"});
  EXPECT_EQ(error_of([&] { writer.write(0.5, Pose2{}, Twist2{}); }),
            file.string() + ": row at t=0.5: expected 1 extra values, found 0");
  EXPECT_EQ(error_of([&] {
              writer.write(0.5, Pose2{}, Twist2{}, {"a", "b"});
            }),
            file.string() + ": row at t=0.5: expected 1 extra values, found 2");
}

TEST(OdometryWriter, ValuesThatWouldBreakTheCsvAreRejected) {
  const TempDir dir;
  const auto file = dir / "odometry.csv";
  OdometryWriter writer(file, {"source"});
  EXPECT_EQ(
      error_of([&] { writer.write(1, Pose2{}, Twist2{}, {"a,b"}); }),
      file.string() + ": row at t=1: value of column 'source' contains a comma or a line break");
  EXPECT_EQ(error_of([&] { OdometryWriter bad(dir / "x.csv", {"a\nb"}); }),
            (dir / "x.csv").string() + ": invalid column name 'a\\x0ab'");
  EXPECT_EQ(error_of([&] { OdometryWriter bad(dir / "x.csv", {"theta"}); }),
            (dir / "x.csv").string() + ": duplicate column 'theta'");
  // Nothing: the refused writers left no file, and the open writer's
  // temporary has no name until commit() (O_TMPFILE, Linux).
  EXPECT_EQ(dir.entries(), 0u);
}

TEST(OdometryWriter, NonFiniteValuesAndBackwardTimeAreRejected) {
  const TempDir dir;
  const auto file = dir / "odometry.csv";
  OdometryWriter writer(file);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(error_of([&] {
              writer.write(1, Pose2{{0, nan}, 0}, Twist2{});
            }),
            file.string() + ": row at t=1: y is not finite (nan)");
  writer.write(1, Pose2{}, Twist2{});
  EXPECT_EQ(error_of([&] { writer.write(0.5, Pose2{}, Twist2{}); }),
            file.string() + ": time goes backwards (0.5 after 1)");
}

TEST(OdometryWriter, WriteAfterCommitIsRejected) {
  const TempDir dir;
  const auto file = dir / "odometry.csv";
  OdometryWriter writer(file);
  writer.commit();
  EXPECT_EQ(error_of([&] { writer.write(0, Pose2{}, Twist2{}); }),
            file.string() + ": write after commit");
  EXPECT_EQ(read_text(file), "t,x,y,theta,vx,vy,omega\n");
}

// ------------------------------------------------------------- AtomicFile

TEST(AtomicFile, CommitReplacesTheTargetWhole) {
  const TempDir dir;
  const auto file = dir.write("out.txt", "old\n");
  AtomicFile out(file);
  out.stream() << "new\n";
  EXPECT_EQ(read_text(file), "old\n");
  out.commit();
  EXPECT_EQ(read_text(file), "new\n");
  EXPECT_EQ(dir.entries(), 1u);
}

TEST(AtomicFile, DestroyedWithoutCommitLeavesNothing) {
  const TempDir dir;
  {
    AtomicFile out(dir / "out.txt");
    out.stream() << "partial";
  }
  EXPECT_EQ(dir.entries(), 0u);
}

TEST(AtomicFile, UnwritableDirectoryIsReported) {
  const TempDir dir;
  const auto file = dir / "no" / "such" / "dir" / "out.txt";
  EXPECT_EQ(error_of([&] { AtomicFile out(file); }),
            file.string() + ": cannot open for writing (No such file or directory)");
}

TEST(AtomicFile, SecondCommitIsRejected) {
  const TempDir dir;
  AtomicFile out(dir / "out.txt");
  out.commit();
  EXPECT_EQ(error_of([&] { out.commit(); }), (dir / "out.txt").string() + ": already committed");
}

}  // namespace
}  // namespace moa::io
