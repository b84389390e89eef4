// Issue #28's cases that need generated files (a sparse 1 GB file, a FIFO,
// a recording): each through the built `moa`, within 15 s, 1 GB of memory
// and 50 MB a file, with a clear refusal or a result that moa reads back.
// The cases from files of tests/data/bad/ are in test_bad_inputs.cpp.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "moa/formats/config.hpp"
#include "moa/formats/log.hpp"
#include "support/run.hpp"
#include "support/slow.hpp"
#include "support/synth.hpp"

// The silence bound's cases write up to 360 000 epochs before the refusal:
// 0.5 s for the Release program, about two minutes each under ASan.
#define SKIP_WHERE_SLOW() MOA_SKIP_UNDER_SANITIZER("writes 360 000 epochs")

namespace moa {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

const fs::path kExample = fs::path(MOA_SOURCE_DIR) / "examples/logs/mixed-motion";

// A log directory: the example's robot.yaml and `mice` as mice.csv.
fs::path log_with(const std::string& tag, const std::string& mice) {
  const fs::path dir = test::scratch_dir(tag);
  fs::copy_file(kExample / "robot.yaml", dir / "robot.yaml");
  std::ofstream(dir / "mice.csv") << mice;
  return dir;
}

std::string odometry_args(const fs::path& log, const fs::path& out) {
  return "odometry --config " + (log / "robot.yaml").string() + " --log " + log.string() +
         " --out " + out.string();
}

// Data lines (not comments, not the header) of a CSV file.
std::size_t data_lines(const fs::path& file) {
  std::ifstream in(file);
  std::string line;
  std::size_t n = 0;
  bool header = false;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (!header) {
      header = true;
      continue;
    }
    ++n;
  }
  return n;
}

TEST(BoundedInputs, AGigabyteLineOfNulsIsRefusedAfter64KiBAndNotEchoed) {
  const fs::path log = log_with("nul-line", "");
  // Sparse: a 1 GB file of NULs without a line end that takes no disk.
  fs::resize_file(log / "mice.csv", std::uintmax_t{1} << 30);
  const fs::path out = log / "o.csv";
  const auto r = test::run_moa_bounded(odometry_args(log, out));
  EXPECT_EQ(test::limits_exceeded(r), "");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "moa odometry: error: " + (log / "mice.csv").string() +
                       ":1: line longer than 65536 bytes: not a CSV file of moa's\n");
  EXPECT_FALSE(fs::exists(out));
}

TEST(BoundedInputs, AnOverlongLineAfterGoodRowsIsRefusedAtItsLine) {
  const std::string row = "0.01,front," + std::string(70000, '1') + ",0\n";
  const fs::path log = log_with("long-line", "t,sensor,dx,dy\n0,front,0,0\n" + row);
  const auto r = test::run_moa_bounded(odometry_args(log, log / "o.csv"));
  EXPECT_EQ(test::limits_exceeded(r), "");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("mice.csv:3: line longer than 65536 bytes"));
  EXPECT_LT(r.err.size(), 300u);
}

// Near the bound a double still resolves the epoch step: a log at 3.9e9 s
// gives as many epochs, and the same poses to the resolution there, as the
// same log at 0 s.
TEST(BoundedInputs, TimesNearTheBoundGiveTheSameEpochsAsAtZero) {
  std::ostringstream at_zero, at_bound;
  at_zero << "t,sensor,dx,dy\n";
  at_bound << "t,sensor,dx,dy\n";
  const std::vector<std::string> names{"front", "left", "rear", "right"};
  for (int k = 0; k <= 100; ++k) {
    for (const auto& name : names) {
      const int dx = k == 0 ? 0 : 10;
      at_zero << k * 0.01 << "," << name << "," << dx << ",0\n";
      at_bound.precision(17);
      at_bound << 3.9e9 + k * 0.01 << "," << name << "," << dx << ",0\n";
    }
  }
  const fs::path zero = log_with("t-zero", at_zero.str());
  const fs::path bound = log_with("t-bound", at_bound.str());
  const auto a = test::run_moa_bounded(odometry_args(zero, zero / "o.csv"));
  const auto b = test::run_moa_bounded(odometry_args(bound, bound / "o.csv"));
  ASSERT_EQ(a.exit_code, 0) << a.err;
  ASSERT_EQ(b.exit_code, 0) << b.err;
  // 1 s at the default 10 ms epochs.
  EXPECT_EQ(data_lines(zero / "o.csv"), 100u);
  EXPECT_EQ(data_lines(bound / "o.csv"), data_lines(zero / "o.csv"));
}

TEST(BoundedInputs, ANamedPipeAsTheLogIsRefusedClearly) {
  const fs::path log = log_with("fifo", "");
  fs::remove(log / "mice.csv");
  ASSERT_EQ(::mkfifo((log / "mice.csv").c_str(), 0600), 0);
  const auto r = test::run_moa_bounded(odometry_args(log, log / "o.csv"));
  EXPECT_EQ(test::limits_exceeded(r), "");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "moa odometry: error: " + (log / "mice.csv").string() +
                       ": not a regular file (a named pipe): a log is read from files; copy it to "
                       "one first\n");
}

// A directory called mice.csv: named as one, not "no such file".
TEST(BoundedInputs, ADirectoryAsTheLogsMiceIsRefusedClearly) {
  const fs::path log = log_with("mice-dir", "");
  fs::remove(log / "mice.csv");
  fs::create_directory(log / "mice.csv");
  const auto r = test::run_moa_bounded(odometry_args(log, log / "o.csv"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "moa odometry: error: " + (log / "mice.csv").string() +
                       ": not a regular file (a directory): a log is read from files; copy it to "
                       "one first\n");
  EXPECT_FALSE(fs::exists(log / "o.csv"));
}

TEST(BoundedInputs, AnInterruptedRecordingIsRecognisedWithHowToRecover) {
  const fs::path log = log_with("part", "");
  fs::rename(log / "mice.csv", log / "mice.csv.part");
  const auto r = test::run_moa_bounded(odometry_args(log, log / "o.csv"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("the recording was interrupted"));
  EXPECT_THAT(r.err, HasSubstr("mv " + (log / "mice.csv.part").string() + " " +
                               (log / "mice.csv").string()));
}

// The rows of a log but its zero rows at the start time (moa live pins every
// sensor's start with one; they add nothing).
std::vector<SensorRow> rows_of(const fs::path& log, const io::RobotConfig& config) {
  io::MiceReader reader(log, config);
  const double t0 = reader.start_time();
  std::vector<SensorRow> rows;
  while (const auto row = reader.next()) {
    if (row->t == t0 && row->counts.isZero()) continue;
    rows.push_back(*row);
  }
  return rows;
}

std::string replay_args(const fs::path& log, const fs::path& record) {
  return "live --config " + (log / "robot.yaml").string() + " --replay " + log.string() +
         " --speed 200 --quiet --record " + record.string();
}

TEST(BoundedInputs, LiveRecordRefusesToReplaceARecordingWithoutForce) {
  const fs::path record = test::scratch_dir("record");
  std::ofstream(record / "mice.csv") << "t,sensor,dx,dy\n";
  const auto r = test::run_moa_bounded(replay_args(kExample, record));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "moa live: error: --record " + record.string() +
                       ": holds a recording (mice.csv); pass --force to replace it\n");
  EXPECT_EQ(test::read_text(record / "mice.csv"), "t,sensor,dx,dy\n");
  const auto forced = test::run_moa_bounded(replay_args(kExample, record) + " --force");
  EXPECT_EQ(forced.exit_code, 0) << forced.err;
  const io::RobotConfig config = io::read_config(kExample / "robot.yaml");
  EXPECT_EQ(rows_of(record, config).size(), rows_of(kExample, config).size());
}

// A recording made from --replay carries squal and flags: it reads back as
// the very rows replayed.
TEST(BoundedInputs, ARecordingOfAReplayCarriesSqualAndFlags) {
  std::ifstream in(kExample / "mice.csv");
  std::ostringstream mice;
  std::string line;
  int k = 0;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    mice << line
         << (k == 0 ? ",squal,flags"
                    : "," + std::to_string(k * 37 % 256) + "," + std::to_string(k % 5 == 0 ? 2 : 0))
         << "\n";
    ++k;
  }
  const fs::path log = log_with("quality", mice.str());
  const fs::path record = test::scratch_dir("quality-record");
  const auto r = test::run_moa_bounded(replay_args(log, record) + " --force");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::RobotConfig config = io::read_config(log / "robot.yaml");
  const auto given = rows_of(log, config);
  const auto recorded = rows_of(record, config);
  ASSERT_EQ(recorded.size(), given.size());
  for (std::size_t i = 0; i < given.size(); ++i) {
    EXPECT_EQ(recorded[i].t, given[i].t) << i;
    EXPECT_EQ(recorded[i].sensor, given[i].sensor) << i;
    EXPECT_EQ(recorded[i].counts, given[i].counts) << i;
    EXPECT_EQ(recorded[i].squal, given[i].squal) << i;
    EXPECT_EQ(recorded[i].flags, given[i].flags) << i;
  }
}

// One saturated record (the firmware's overflow flag, counts at the int16
// limit) in a live input is reported once and skipped: the run goes on and
// its recording replays with `moa odometry`.
TEST(BoundedInputs, ASaturatedLiveRecordIsSkippedAndTheRecordingReplays) {
  std::ifstream in(kExample / "mice.csv");
  std::ostringstream mice;
  std::string line;
  int k = 0;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (k == 400) line = line.substr(0, line.find(',', line.find(',') + 1)) + ",32767,0";
    mice << line << (k == 0 ? ",squal,flags" : k == 400 ? ",10,1" : ",80,0") << "\n";
    ++k;
  }
  const fs::path log = log_with("saturated", mice.str());
  const fs::path record = test::scratch_dir("saturated-record");
  const auto r = test::run_moa_bounded(replay_args(log, record) + " --force");
  EXPECT_EQ(test::limits_exceeded(r), "");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("skipped: counts imply a speed far beyond"));
  const io::RobotConfig config = io::read_config(log / "robot.yaml");
  EXPECT_EQ(rows_of(record, config).size(), rows_of(log, config).size() - 1);
  const auto replay = test::run_moa_bounded(odometry_args(record, record / "o.csv"));
  EXPECT_EQ(replay.exit_code, 0) << replay.err;
}

// Sparse rows: every sensor of the example's config (front, left, rear,
// right) with zero counts at each of `times`.
std::string rows_at(const std::vector<double>& times, const std::vector<std::string>& names) {
  std::ostringstream mice;
  mice.precision(17);
  mice << "t,sensor,dx,dy\n";
  for (const double t : times) {
    for (const auto& name : names) mice << t << "," << name << ",0,0\n";
  }
  return mice.str();
}

const std::vector<std::string> kNames{"front", "left", "rear", "right"};

// The silence rule as docs/reliability.md states it, with the defaults
// (--max-gap 3600 s, --max-row-interval 0.05 s, 100 Hz): each row adds the
// time since the previous row beyond 0.05 s; a row is refused when the sum
// exceeds 3600 s plus 0.01 s for each row before it. Returns the refused
// row's line in mice.csv (the header is line 1), 0 if none.
std::size_t first_refused_line(const std::vector<double>& row_times) {
  double silence = 0.0;
  double last = row_times.front();
  for (std::size_t i = 0; i < row_times.size(); ++i) {
    silence += std::max(0.0, row_times[i] - last - 0.05);
    if (silence > 3600.0 + 0.01 * static_cast<double>(i)) return i + 2;
    last = row_times[i];
  }
  return 0;
}

std::vector<double> every(double step, double span) {
  std::vector<double> times;
  for (int k = 0; k * step <= span; ++k) times.push_back(k * step);
  return times;
}

std::vector<double> repeated(const std::vector<double>& times, std::size_t n) {
  std::vector<double> rows;
  for (const double t : times) rows.insert(rows.end(), n, t);
  return rows;
}

// Rows an hour apart over a day would write 8.64 million still epochs (850
// MB): refused at the second gap, the numbers and the flag named.
TEST(BoundedInputs, RowsAnHourApartOverADayAreRefusedAtTheSecondGap) {
  SKIP_WHERE_SLOW();
  const auto times = every(3599.0, 86400.0);
  const fs::path log = log_with("hour-apart", rows_at(times, kNames));
  const auto r = test::run_moa_bounded(odometry_args(log, log / "o.csv"));
  EXPECT_EQ(test::limits_exceeded(r), "");
  EXPECT_EQ(r.exit_code, 1);
  // Lines 2-5 at t = 0, 6-9 at 3599 s, 10 the first at 7198 s.
  ASSERT_EQ(first_refused_line(repeated(times, kNames.size())), 10u);
  EXPECT_THAT(r.err, HasSubstr("mice.csv:10: row at t = 7198 s: the sensors have been silent "
                               "for 7197.90 s in total by this row"));
  EXPECT_THAT(r.err, HasSubstr("more than the 3600.08 s allowed: --max-gap 3600 s plus 0.01 s "
                               "(one epoch) for each of the 8 rows before it"));
  EXPECT_FALSE(fs::exists(log / "o.csv"));
}

// The variants: rows 59 s apart over a day; one sensor once a second for a
// day while the others stay silent. Each refused at the row the rule names.
TEST(BoundedInputs, SparseRowsAreRefusedWhereTheirSilencesExceedTheBound) {
  SKIP_WHERE_SLOW();
  struct Case {
    std::string tag;
    std::vector<double> times;
    std::vector<std::string> names;
  };
  const std::vector<Case> cases{{"59s-apart", every(59.0, 86400.0), kNames},
                                {"one-sensor-1hz", every(1.0, 86400.0), {"front"}}};
  for (const auto& c : cases) {
    SCOPED_TRACE(c.tag);
    const fs::path log = log_with(c.tag, rows_at(c.times, c.names));
    const auto r = test::run_moa_bounded(odometry_args(log, log / "o.csv"));
    EXPECT_EQ(test::limits_exceeded(r), "");
    EXPECT_EQ(r.exit_code, 1);
    const std::size_t line = first_refused_line(repeated(c.times, c.names.size()));
    ASSERT_GT(line, 0u);
    EXPECT_THAT(r.err, HasSubstr("mice.csv:" + std::to_string(line) + ": row at t = "));
    EXPECT_THAT(r.err, HasSubstr("--max-gap 3600 s plus 0.01 s"));
    EXPECT_FALSE(fs::exists(log / "o.csv"));
  }
}

// Within the bound: one gap of 3599 s (a parked robot) is written epoch by
// epoch, and a silence raised by --max-gap is accepted; both read back.
TEST(BoundedInputs, ASilenceWithinTheBoundIsWrittenEpochByEpoch) {
  SKIP_WHERE_SLOW();
  const fs::path log = log_with("one-gap", rows_at({0.0, 3599.0}, kNames));
  const auto r = test::run_moa_bounded(odometry_args(log, log / "o.csv"));
  EXPECT_EQ(test::limits_exceeded(r), "");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(data_lines(log / "o.csv"), 359900u);  // 3599 s / 10 ms

  const fs::path sparse = log_with("raised", rows_at(every(59.0, 600.0), kNames));
  const auto raised =
      test::run_moa_bounded(odometry_args(sparse, sparse / "o.csv") + " --max-gap 100");
  EXPECT_EQ(raised.exit_code, 1);
  EXPECT_THAT(raised.err, HasSubstr("--max-gap 100 s plus"));
  const auto ok =
      test::run_moa_bounded(odometry_args(sparse, sparse / "o.csv") + " --max-gap 1000");
  ASSERT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_EQ(data_lines(sparse / "o.csv"), 59000u);  // the last row at 590 s
}

// `moa live --replay` bounds a log's silences as `moa odometry` does: at
// --speed the still epochs would come faster than real time.
TEST(BoundedInputs, AReplayOfRowsAnHourApartIsRefusedAsByOdometry) {
  SKIP_WHERE_SLOW();
  const fs::path log = log_with("replay-hour-apart", rows_at(every(3599.0, 86400.0), kNames));
  const auto r = test::run_moa_bounded(
      "live --config " + (log / "robot.yaml").string() + " --replay " + log.string() +
      " --speed 1000000 --quiet --out " + (log / "o.csv").string());
  EXPECT_EQ(test::limits_exceeded(r), "");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr(log.string() +
                               ": row at t = 7198 s: the sensors have been silent for 7197.90 s "
                               "in total by this row"));
  EXPECT_FALSE(fs::exists(log / "o.csv"));
}

// A full disk: the error names the file and says "No space left on
// device", and no file (nor a temporary) is left. The disk is a tmpfs of 64
// KiB mounted in a user and mount namespace of its own (`unshare -r -m`),
// smaller than the example's odometry.csv; where the kernel or the
// container forbids that, the test is skipped and says why.
TEST(BoundedInputs, AFullDiskIsSaidWithTheFileAndLeavesNothing) {
  const fs::path dir = test::scratch_dir("disk-full");
  const fs::path full = dir / "full";
  fs::create_directory(full);
  const std::string out = (full / "o.csv").string();
  const std::string script = "mount -t tmpfs -o size=64k tmpfs " + full.string() + " || exit 77; " +
                             MOA_CLI_PATH + " " + odometry_args(kExample, out) + " 2>" +
                             (dir / "err").string() + "; echo $? >" + (dir / "code").string() +
                             "; ls -A " + full.string() + " >" + (dir / "left").string();
  const std::string command =
      "unshare -r -m sh -c '" + script + "' 2>" + (dir / "unshare-err").string();
  const int status = std::system(command.c_str());
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    GTEST_SKIP() << "cannot mount a small tmpfs in a namespace of its own (`unshare -r -m`, "
                    "then `mount -t tmpfs`): "
                 << test::read_text(dir / "unshare-err");
  }
  EXPECT_EQ(test::read_text(dir / "code"), "3\n");  // an output that cannot be written
  EXPECT_EQ(test::read_text(dir / "err"),
            "moa odometry: error: " + out + ": cannot write (No space left on device)\n");
  EXPECT_EQ(test::read_text(dir / "left"), "");  // nothing in the full file system
}

// A full disk under `moa live --record` stops the recording, said once, and
// the run goes on: --out on another disk is written, the same odometry as
// `moa odometry` of the replayed log, and the recording's error ends the
// run (issue #47, item 10: --out was lost with the recording).
TEST(BoundedInputs, AFullDiskUnderLiveRecordKeepsTheOtherOutputs) {
  const fs::path dir = test::scratch_dir("disk-full-live");
  const fs::path full = dir / "full";
  fs::create_directory(full);
  const fs::path out = dir / "live.csv";
  const std::string script =
      "mount -t tmpfs -o size=64k tmpfs " + full.string() + " || exit 77; " + MOA_CLI_PATH +
      " live --config " + kExample.string() + "/robot.yaml --replay " + kExample.string() +
      " --speed 1000000 --quiet --record " + (full / "rec").string() + " --out " + out.string() +
      " 2>" + (dir / "err").string() + "; echo $? >" + (dir / "code").string();
  const std::string command =
      "unshare -r -m sh -c '" + script + "' 2>" + (dir / "unshare-err").string();
  const int status = std::system(command.c_str());
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    GTEST_SKIP() << "cannot mount a small tmpfs in a namespace of its own (`unshare -r -m`, "
                    "then `mount -t tmpfs`): "
                 << test::read_text(dir / "unshare-err");
  }
  EXPECT_EQ(test::read_text(dir / "code"), "1\n");
  const std::string err = test::read_text(dir / "err");
  const std::string mice = (full / "rec" / "mice.csv").string();
  // The reason is the system's (ENOSPC, or EIO where the failed write is
  // reported at the flush): the message names the file and stops there.
  const std::string said =
      "moa live: warning: --record " + (full / "rec").string() + ": " + mice + ": cannot write (";
  const auto first = err.find(said);
  ASSERT_NE(first, std::string::npos) << err;
  EXPECT_NE(err.find("): the recording stops here", first), std::string::npos) << err;
  EXPECT_EQ(err.find(said, first + 1), std::string::npos) << "said once: " << err;
  EXPECT_NE(err.find("moa live: error: " + mice + ": cannot write ("), std::string::npos) << err;
  ASSERT_TRUE(fs::exists(out)) << err;
  const fs::path offline = dir / "offline.csv";
  const auto o = test::run_moa("odometry --config " + kExample.string() + "/robot.yaml --log " +
                               kExample.string() + " --quiet --out " + offline.string());
  ASSERT_EQ(o.exit_code, 0) << o.err;
  EXPECT_EQ(test::read_text(out), test::read_text(offline));
}

// The firmware runs at 500000 baud (docs/firmware.md): so does --serial
// unless --baud says otherwise.
TEST(BoundedInputs, BaudDefaultsToTheFirmwares) {
  const auto r = test::run_moa_bounded("live --help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_THAT(r.out, ::testing::HasSubstr("--baud INT=500000"));
}

}  // namespace
}  // namespace moa
