// Careless calls and bad data that used to go wrong quietly: each is now
// refused at once with a message naming the option, file or line, and with
// the documented exit code (io/error.hpp ExitCode), and no output is left.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "exit_codes.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

const std::string kExample = std::string(MOA_SOURCE_DIR) + "/examples/logs/mixed-motion";

/// A copy of the example log in a scratch directory, for tests that change it.
fs::path example_copy(const std::string& tag) {
  const fs::path dir = test::scratch_dir(tag);
  for (const char* f : {"mice.csv", "robot.yaml", "truth.csv"}) {
    fs::copy_file(fs::path(kExample) / f, dir / f);
  }
  return dir;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string odometry(const fs::path& dir, const std::string& extra) {
  return "odometry --config " + (dir / "robot.yaml").string() + " --log " + dir.string() + " " +
         extra;
}

TEST(CarelessCalls, OutputOntoItsOwnInputIsRefusedAndTheInputKept) {
  const fs::path dir = example_copy("careless-out");
  const std::string before = slurp(dir / "mice.csv");
  const auto r = test::run_moa(odometry(dir, "--out " + (dir / "mice.csv").string()));
  EXPECT_EQ(r.exit_code, cli::kExitBadInput);
  EXPECT_THAT(r.err, HasSubstr("--out " + (dir / "mice.csv").string() + ": is an input"));
  EXPECT_EQ(slurp(dir / "mice.csv"), before);
  // The same file by another spelling.
  const auto r2 = test::run_moa(odometry(dir, "--out " + (dir / "." / "robot.yaml").string()));
  EXPECT_EQ(r2.exit_code, cli::kExitBadInput);
  EXPECT_THAT(r2.err, HasSubstr("is an input"));
}

TEST(CarelessCalls, SelfCalibrationFileOntoAnInputOrTheOdometryIsRefused) {
  const fs::path dir = example_copy("careless-self-calibration");
  const fs::path out = dir / "odometry.csv";
  for (const fs::path& target : {dir / "mice.csv", dir / "robot.yaml"}) {
    const std::string before = slurp(target);
    const auto r = test::run_moa(
        odometry(dir, "--out " + out.string() + " --self-calibration " + target.string()));
    EXPECT_EQ(r.exit_code, cli::kExitBadInput) << r.err;
    EXPECT_THAT(r.err, HasSubstr("--self-calibration " + target.string() + ": is an input"));
    EXPECT_EQ(slurp(target), before);
  }
  const auto r =
      test::run_moa(odometry(dir, "--out " + out.string() + " --self-calibration " + out.string()));
  EXPECT_EQ(r.exit_code, cli::kExitBadInput) << r.err;
  EXPECT_THAT(r.err,
              HasSubstr("--self-calibration " + out.string() + ": is the --out of this run"));
  EXPECT_FALSE(fs::exists(out));
}

// --self-calibration takes a file name: not an empty one (nothing would be
// written) nor the next option (`--self-calibration --quiet` wrote a file
// named --quiet); a usage error (exit 2) naming the option, nothing written.
TEST(CarelessCalls, SelfCalibrationFileNameIsNotAnOption) {
  const fs::path dir = example_copy("careless-self-calibration-name");
  const fs::path out = dir / "odometry.csv";
  for (const std::string& value : {std::string("--quiet"), std::string("''"), std::string("-")}) {
    for (const std::string& command :
         {odometry(dir, "--out " + out.string()),
          "live --config " + (dir / "robot.yaml").string() + " --replay " + dir.string() +
              " --speed 1000 --quiet --out " + out.string()}) {
      const auto r = test::run_moa(command + " --self-calibration " + value);
      EXPECT_EQ(r.exit_code, cli::kExitUsage) << command << " " << value << "\n" << r.err;
      EXPECT_THAT(r.err, HasSubstr("--self-calibration: ")) << value;
      EXPECT_FALSE(fs::exists(out)) << command << " " << value;
      EXPECT_FALSE(fs::exists(fs::current_path() / "--quiet"));
    }
  }
}

// An empty --out is a usage error naming the option, as an empty
// --self-calibration is (it was "error: : cannot write" at exit 3).
TEST(CarelessCalls, AnEmptyOutIsAUsageError) {
  const fs::path dir = example_copy("careless-empty-out");
  for (const std::string& command :
       {odometry(dir, "--out ''"), std::string("simulate --scenario kimlee --out ''"),
        "calibrate --config " + (dir / "robot.yaml").string() + " --method kimlee --log " +
            dir.string() + " --out ''"}) {
    const auto r = test::run_moa(command);
    EXPECT_EQ(r.exit_code, cli::kExitUsage) << command << "\n" << r.err;
    EXPECT_THAT(r.err, HasSubstr("--out: an empty file name")) << command;
  }
}

// A log directory without mice.csv: a file that cannot be opened (exit 3,
// docs/formats/cli.md), named.
TEST(CarelessCalls, ALogWithoutMiceCsvIsAFileThatCannotBeOpened) {
  const fs::path dir = test::scratch_dir("careless-no-mice");
  fs::create_directories(dir / "log");
  const auto r = test::run_moa("odometry --config " + kExample + "/robot.yaml --log " +
                               (dir / "log").string() + " --out " + (dir / "o.csv").string());
  EXPECT_EQ(r.exit_code, cli::kExitIo) << r.err;
  EXPECT_THAT(r.err, HasSubstr((dir / "log" / "mice.csv").string() + ": no such file"));
  EXPECT_FALSE(fs::exists(dir / "o.csv"));
}

// An empty name in --sensors (a doubled or trailing comma) is a usage
// error, not dropped; "a,b" and "a b" select the same sensors.
TEST(CarelessCalls, AnEmptySensorNameIsAUsageError) {
  const fs::path dir = example_copy("careless-sensors");
  for (const char* list : {"front,,left", "front,", ",front", "''"}) {
    const auto r = test::run_moa(
        odometry(dir, std::string("--sensors ") + list + " --out " + (dir / "o.csv").string()));
    EXPECT_EQ(r.exit_code, cli::kExitUsage) << list << "\n" << r.err;
    EXPECT_THAT(r.err, HasSubstr("--sensors: an empty sensor name in")) << list;
  }
  EXPECT_FALSE(fs::exists(dir / "o.csv"));
  const auto comma = test::run_moa(
      odometry(dir, "--sensors front,left,rear --out " + (dir / "comma.csv").string()));
  const auto space = test::run_moa(
      odometry(dir, "--sensors front left rear --out " + (dir / "space.csv").string()));
  ASSERT_EQ(comma.exit_code, 0) << comma.err;
  ASSERT_EQ(space.exit_code, 0) << space.err;
  EXPECT_EQ(slurp(dir / "comma.csv"), slurp(dir / "space.csv"));
  EXPECT_THAT(slurp(dir / "comma.csv"), HasSubstr("right:unselected"));
}

TEST(CarelessCalls, ADirectoryAsAnOutputFileIsAUsageError) {
  const fs::path dir = example_copy("careless-dir-out");
  const fs::path sub = dir / "results";
  fs::create_directories(sub);
  const std::string config = (dir / "robot.yaml").string();
  for (const std::string& name : {sub.string(), sub.string() + "/", (dir / "new").string() + "/"}) {
    for (const std::string& command :
         {odometry(dir, "--out " + name),
          odometry(dir, "--out " + (dir / "o.csv").string() + " --diagnostics " + name),
          odometry(dir, "--out " + (dir / "o.csv").string() + " --self-calibration " + name),
          "calibrate --config " + config + " --method kimlee --log " + dir.string() + " --out " +
              name,
          "live --config " + config + " --replay " + dir.string() + " --out " + name}) {
      const auto r = test::run_moa(command);
      EXPECT_EQ(r.exit_code, cli::kExitUsage) << command << "\n" << r.err;
      EXPECT_THAT(r.err, HasSubstr("'" + name + "' is a directory")) << command;
    }
  }
  EXPECT_FALSE(fs::exists(dir / "new")) << "nothing is created";
  EXPECT_FALSE(fs::exists(dir / "o.csv")) << "nothing is written";
}

// An empty name, or an option taken for one, is a usage error for the
// live run's --out and --record as for odometry's outputs ('-' is --out's
// standard output); nothing is written.
TEST(CarelessCalls, AnEmptyOrOptionLikeLiveOutputIsAUsageError) {
  const fs::path dir = example_copy("careless-live-names");
  const std::string live = "live --config " + (dir / "robot.yaml").string() + " --replay " +
                           dir.string() + " --speed 1000 ";
  for (const std::string& args : {std::string("--out ''"), std::string("--out --quiet"),
                                  std::string("--record ''"), std::string("--record --quiet")}) {
    const auto r = test::run_moa(live + args);
    EXPECT_EQ(r.exit_code, cli::kExitUsage) << args << "\n" << r.err;
  }
  EXPECT_FALSE(fs::exists("--quiet"));
  const auto r = test::run_moa(live + "--quiet --out -");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("t,x,y,theta"));
}

// Every command that writes refuses an output that names one of its
// inputs, before it writes anything (issue #20); `what` is the start of
// the message after the option and path.
void expect_refused(const std::string& args, const std::string& option, const fs::path& out,
                    const std::string& what = "is an input of this run") {
  const std::string before = fs::is_regular_file(out) ? slurp(out) : std::string();
  const auto r = test::run_moa(args);
  EXPECT_EQ(r.exit_code, cli::kExitBadInput) << args << "\n" << r.err;
  EXPECT_THAT(r.err, HasSubstr(option + " " + out.string() + ": " + what)) << args;
  if (fs::is_regular_file(out)) {
    EXPECT_EQ(slurp(out), before) << args;
  }
}

TEST(CarelessCalls, CalibrateAndReportRefuseAnOutputOntoAnInput) {
  const fs::path dir = example_copy("careless-out-calibrate");
  const std::string config = (dir / "robot.yaml").string();
  const std::string calibrate =
      "calibrate --config " + config + " --log " + dir.string() + " --method exact --out ";
  expect_refused(calibrate + config, "--out", config);  // the nominal config itself
  expect_refused(calibrate + (dir / "mice.csv").string(), "--out", dir / "mice.csv");
  expect_refused(calibrate + (dir / "truth.csv").string(), "--out", dir / "truth.csv");
  const std::string guided = "calibrate --config " + config + " --method guided --push-x " +
                             dir.string() + " --spin " + dir.string() +
                             " --distance 1 --turns 5 --out ";
  expect_refused(guided + (dir / "mice.csv").string(), "--out", dir / "mice.csv");
  const std::string live_guided =
      "calibrate --guided --live --config " + config + " --replay " + dir.string() + " --out ";
  expect_refused(live_guided + config, "--out", config);
  // The live session has the array alone to calibrate the gyro against.
  const auto wheels =
      test::run_moa(live_guided + (dir / "cal.yaml").string() + " --imu-reference wheels");
  EXPECT_EQ(wheels.exit_code, cli::kExitBadInput) << wheels.err;
  EXPECT_THAT(wheels.err, HasSubstr("--imu-reference wheels: the live guided calibration "
                                    "calibrates the gyro against the array only"));
  EXPECT_FALSE(fs::exists(dir / "cal.yaml"));

  const std::string report = "report --config " + config + " --log " + dir.string() +
                             " --odometry " + (dir / "truth.csv").string() + " --out ";
  for (const char* f : {"robot.yaml", "mice.csv", "truth.csv"}) {
    expect_refused(report + (dir / f).string(), "--out", dir / f);
  }
}

TEST(CarelessCalls, ImportLiveAndSimulateRefuseAnOutputOntoAnInput) {
  const fs::path dir = example_copy("careless-out-live");
  const std::string config = (dir / "robot.yaml").string();
  // import-evemu writes DIR/mice.csv: a recording of that name is refused.
  const fs::path rec = dir / "rec";
  fs::create_directories(rec);
  fs::copy_file(std::string(MOA_TEST_DATA_DIR) + "/evemu/ps2-generic-mouse.events",
                rec / "mice.csv");
  expect_refused(
      "import-evemu --sensor m1=" + (rec / "mice.csv").string() + " --out " + rec.string(), "--out",
      rec / "mice.csv");

  // live: --record DIR writes DIR/mice.csv and DIR/robot.yaml, --out FILE.
  const std::string live =
      "live --config " + config + " --replay " + dir.string() + " --speed 1000 --quiet ";
  expect_refused(live + "--record " + dir.string(), "--record", dir / "mice.csv");
  expect_refused(live + "--out " + config, "--out", config);
  expect_refused(live + "--out " + (dir / "truth.csv").string(), "--out", dir / "truth.csv");
  expect_refused(
      live + "--record " + (dir / "r").string() + " --out " + (dir / "r" / "mice.csv").string(),
      "--out", dir / "r" / "mice.csv", "is written by --record too");
  // The streams' files in the recording too: written by it, or removed.
  for (const char* name : {"wheels.csv", "imu.csv", "camera.csv"}) {
    expect_refused(
        live + "--record " + (dir / "r").string() + " --out " + (dir / "r" / name).string(),
        "--out", dir / "r" / name, "is written by --record too");
    expect_refused(live + "--record " + (dir / "r").string() + " --out " +
                       (dir / "o.csv").string() + " --diagnostics " + (dir / "r" / name).string(),
                   "--diagnostics", dir / "r" / name, "is written by --record too");
  }
  EXPECT_FALSE(fs::exists(dir / "r"));
  // --self-calibration FILE: not an input, not the recording, not the --out.
  expect_refused(live + "--out " + (dir / "o.csv").string() + " --self-calibration " +
                     (dir / "mice.csv").string(),
                 "--self-calibration", dir / "mice.csv");
  expect_refused(live + "--self-calibration " + config, "--self-calibration", config);
  expect_refused(live + "--record " + (dir / "r").string() + " --self-calibration " +
                     (dir / "r" / "mice.csv").string(),
                 "--self-calibration", dir / "r" / "mice.csv", "is written by --record too");
  EXPECT_FALSE(fs::exists(dir / "r"));
  expect_refused(live + "--out " + (dir / "o.csv").string() + " --self-calibration " +
                     (dir / "o.csv").string(),
                 "--self-calibration", dir / "o.csv", "is the --out of this run");
  EXPECT_FALSE(fs::exists(dir / "o.csv"));

  // simulate replaces its --out directory whole: not one holding the scenario.
  const fs::path run = dir / "run";
  const auto first = test::run_moa("simulate --scenario kimlee --quiet --out " + run.string());
  ASSERT_EQ(first.exit_code, 0) << first.err;
  fs::copy_file(std::string(MOA_SOURCE_DIR) + "/examples/scenarios/kimlee.yaml",
                run / "kimlee.yaml");
  expect_refused("simulate --scenario " + (run / "kimlee.yaml").string() + " --out " + run.string(),
                 "--out", run, "holds " + (run / "kimlee.yaml").string());
  EXPECT_TRUE(fs::exists(run / "kimlee.yaml"));
}

TEST(CarelessCalls, NotANumberIsRefusedNamingTheOption) {
  const fs::path out = test::scratch_dir("careless-nan") / "o.csv";
  for (const std::string option : {"--rate", "--max-row-interval", "--alpha", "--e-th"}) {
    const auto r = test::run_moa("odometry --config " + kExample + "/robot.yaml --log " + kExample +
                                 " " + option + " nan --out " + out.string());
    EXPECT_EQ(r.exit_code, cli::kExitUsage) << option;
    EXPECT_THAT(r.err, HasSubstr(option)) << option;
    EXPECT_THAT(r.err, HasSubstr("not a finite number")) << option << r.err;
  }
  const auto r = test::run_moa("odometry --config " + kExample + "/robot.yaml --log " + kExample +
                               " --initial-pose nan,0,0 --out " + out.string());
  EXPECT_EQ(r.exit_code, cli::kExitUsage);
  EXPECT_THAT(r.err, HasSubstr("--initial-pose"));
  // Every subcommand's floating-point options, not only odometry's.
  const auto s = test::run_moa("evaluate --truth " + kExample + "/truth.csv --odometry " +
                               kExample + "/truth.csv --json");
  EXPECT_EQ(s.exit_code, 0) << s.err;
  EXPECT_FALSE(fs::exists(out));
}

TEST(CarelessCalls, InfinityAndOutOfRangeNumbersGetOneShortMessage) {
  // CLI11's own ranges printed 1.797...e308 in full, and "(inf is not a
  // finite number) AND (Value inf not in range ...)".
  const std::string out = (test::scratch_dir("careless-range") / "o").string();
  const std::string odometry_args =
      "odometry --config " + kExample + "/robot.yaml --log " + kExample + " --out " + out + " ";
  const std::string guided = "calibrate --config " + kExample + "/robot.yaml --method guided " +
                             "--push-x " + kExample + " --spin " + kExample +
                             " --distance 1 --turns 5 --out " + out + " ";
  const std::vector<std::pair<std::string, std::string>> cases{
      {odometry_args + "--rate inf", "--rate: inf is not a finite number\n"},
      {odometry_args + "--rate 0", "--rate: 0: must be within [0.1, 10000]\n"},
      // --help says "1e-12 to below 0.5": 0.5 itself is refused by the flag
      // (exit 2), not by the library's options (exit 1).
      {odometry_args + "--alpha 0.5", "--alpha: 0.5: must be within [1e-12, 0.5)\n"},
      {odometry_args + "--camera-latency -61", "--camera-latency: -61: must be within [-60, 60]\n"},
      {guided + "--turn-sd inf", "--turn-sd: inf is not a finite number\n"},
      {guided + "--max-row-interval -1", "--max-row-interval: -1: must be > 0\n"},
      {"live --config " + kExample + "/robot.yaml --replay " + kExample + " --speed -1",
       "--speed: -1: must be > 0\n"},
  };
  for (const auto& [args, message] : cases) {
    const auto r = test::run_moa(args);
    EXPECT_EQ(r.exit_code, cli::kExitUsage) << args;
    EXPECT_EQ(r.err, message + "Run with --help for more information.\n") << args;
  }
  EXPECT_FALSE(fs::exists(out));
}

// The ends of --rate's range: each runs, or is refused saying why and with
// the flag that helps (a tester found them refused by a field's name, or
// by a bound no flag names).
TEST(CarelessCalls, RatesAtTheEndsOfTheirRangeRunOrSayWhy) {
  const fs::path dir = test::scratch_dir("careless-rates");
  const std::string odometry = "odometry --config " + kExample + "/robot.yaml --log " + kExample;
  // 5000 Hz: the default --max-row-interval (0.05 s) would be 250 epochs,
  // beyond the synchroniser's ring of 61; not given, it is 60 epochs (12
  // ms: the log's 100 Hz rows still cover their 10 ms, no epoch is held).
  const auto fast = test::run_moa(odometry + " --rate 5000 --out " + (dir / "fast.csv").string());
  EXPECT_EQ(fast.exit_code, 0) << fast.err;
  EXPECT_THAT(fast.out, Not(HasSubstr("not usable"))) << fast.out;
  // Given beyond the ring, it is refused by its flag.
  const auto given =
      test::run_moa(odometry + " --max-row-interval 5 --out " + (dir / "given.csv").string());
  EXPECT_EQ(given.exit_code, 1);
  EXPECT_THAT(given.err, HasSubstr("invalid option: --max-row-interval: must be <= 61 periods"))
      << given.err;
  EXPECT_FALSE(fs::exists(dir / "given.csv"));
  // 0.5 Hz against 100 Hz wheels: an epoch is 200 wheel rows, more than
  // the 256-row ring holds with the rows fed ahead: refused saying so.
  const fs::path log = dir / "log";
  ASSERT_EQ(test::run_moa("simulate --scenario kimlee --quiet --out " + log.string()).exit_code, 0);
  const auto slow =
      test::run_moa("odometry --config " + (log / "robot.yaml").string() + " --log " +
                    log.string() + " --rate 0.5 --out " + (dir / "slow.csv").string());
  EXPECT_EQ(slow.exit_code, 1);
  EXPECT_THAT(slow.err, HasSubstr("wheel rows fed too far ahead of the mice rows (at most 256 rows "
                                  "are kept ahead of the mice rows; an epoch is 2 s at --rate 0.5"))
      << slow.err;
  EXPECT_FALSE(fs::exists(dir / "slow.csv"));
  // The wheels estimator on a log without wheels.csv: refused, not a run
  // of holds.
  const auto wheels =
      test::run_moa(odometry + " --estimator wheels --out " + (dir / "wheels.csv").string());
  EXPECT_EQ(wheels.exit_code, 1);
  EXPECT_THAT(wheels.err,
              HasSubstr(kExample + "/wheels.csv: the wheels estimator needs wheels.csv in the log"))
      << wheels.err;
  EXPECT_FALSE(fs::exists(dir / "wheels.csv"));
  // --faults with another estimator than the oracle: refused, not ignored.
  const auto faults = test::run_moa(odometry + " --faults " + kExample + "/truth.csv --out " +
                                    (dir / "faults.csv").string());
  EXPECT_EQ(faults.exit_code, 1);
  EXPECT_THAT(faults.err, HasSubstr("--faults is read by --estimator oracle only (the estimator is "
                                    "consensus)"))
      << faults.err;
  EXPECT_FALSE(fs::exists(dir / "faults.csv"));
  // One sensor selected of four, without a gyro: refused, not the wheels
  // in every epoch.
  const auto one = test::run_moa(odometry + " --sensors front --out " + (dir / "one.csv").string());
  EXPECT_EQ(one.exit_code, 1);
  EXPECT_THAT(one.err, HasSubstr("one sensor (the one --sensors selects) needs a gyro")) << one.err;
  EXPECT_FALSE(fs::exists(dir / "one.csv"));
  // The oracle with a faults.csv longer than mice.csv (another log's):
  // refused, not read as far as mice.csv goes.
  const fs::path longer = dir / "faults-longer.csv";
  fs::copy_file(log / "faults.csv", longer);
  const std::string faults_text = slurp(longer);
  std::ofstream(longer, std::ios::app)
      << faults_text.substr(faults_text.rfind('\n', faults_text.size() - 2) + 1);
  const auto oracle = test::run_moa("odometry --config " + (log / "robot.yaml").string() +
                                    " --log " + log.string() + " --estimator oracle --faults " +
                                    longer.string() + " --out " + (dir / "oracle.csv").string());
  EXPECT_EQ(oracle.exit_code, 1);
  EXPECT_THAT(oracle.err, HasSubstr(longer.string() + ":"));
  EXPECT_THAT(oracle.err, HasSubstr("has rows past mice.csv's end")) << oracle.err;
  EXPECT_FALSE(fs::exists(dir / "oracle.csv"));
}

TEST(CarelessCalls, DuplicatedRowIsRefusedWithItsLine) {
  const fs::path dir = example_copy("careless-dup");
  std::string text = slurp(dir / "mice.csv");
  // Repeat line 100 (a row with counts) right after itself.
  std::size_t a = 0;
  for (int k = 0; k < 99; ++k) a = text.find('\n', a) + 1;
  const std::size_t b = text.find('\n', a) + 1;
  text.insert(b, text.substr(a, b - a));
  std::ofstream(dir / "mice.csv") << text;
  const auto r = test::run_moa(odometry(dir, "--estimator ls --out " + (dir / "o.csv").string()));
  EXPECT_EQ(r.exit_code, cli::kExitBadInput);
  EXPECT_THAT(r.err, HasSubstr("mice.csv:101: duplicate row: sensor"));
  EXPECT_THAT(r.err, HasSubstr("(line 100)"));
  EXPECT_FALSE(fs::exists(dir / "o.csv"));
}

TEST(CarelessCalls, SilentSensorIsRefusedForLeastSquaresAndWarnedForConsensus) {
  const fs::path dir = example_copy("careless-silent");
  // Drop every row of one sensor.
  std::stringstream in(slurp(dir / "mice.csv"));
  std::string kept, line, silent;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line.rfind("t,", 0) == 0) {
      kept += line + "\n";  // comments and the header
      continue;
    }
    const auto c1 = line.find(',');
    const std::string name = line.substr(c1 + 1, line.find(',', c1 + 1) - c1 - 1);
    if (silent.empty()) silent = name;
    if (name != silent) kept += line + "\n";
  }
  std::ofstream(dir / "mice.csv") << kept;
  const auto r = test::run_moa(odometry(dir, "--estimator ls --out " + (dir / "o.csv").string()));
  EXPECT_EQ(r.exit_code, cli::kExitBadInput);
  EXPECT_THAT(r.err, HasSubstr("sensor '" + silent + "'"));
  EXPECT_THAT(r.err, HasSubstr("never reports"));
  EXPECT_FALSE(fs::exists(dir / "o.csv"));
  const auto c = test::run_moa(odometry(dir, "--out " + (dir / "o.csv").string()));
  EXPECT_EQ(c.exit_code, 0) << c.err;
  EXPECT_THAT(c.err, HasSubstr("warning"));
  EXPECT_THAT(c.err, HasSubstr("never reports"));
  EXPECT_TRUE(fs::exists(dir / "o.csv"));
}

TEST(CarelessCalls, ImpossibleCountsAreRefusedWithTheLine) {
  const fs::path dir = example_copy("careless-counts");
  std::string text = slurp(dir / "mice.csv");
  // Line 10's dx becomes 2e9 counts: 63 km at 800 cpi within 10 ms.
  std::size_t a = 0;
  for (int k = 0; k < 9; ++k) a = text.find('\n', a) + 1;
  const std::size_t c1 = text.find(',', a), c2 = text.find(',', c1 + 1),
                    c3 = text.find(',', c2 + 1);
  text.replace(c2 + 1, c3 - c2 - 1, "2000000000");
  std::ofstream(dir / "mice.csv") << text;
  const auto r = test::run_moa(odometry(dir, "--estimator ls --out " + (dir / "o.csv").string()));
  EXPECT_EQ(r.exit_code, cli::kExitBadInput);
  EXPECT_THAT(r.err, HasSubstr("mice.csv:10: row at t = "));
  EXPECT_THAT(r.err, HasSubstr("far beyond what the sensor can track"));
  EXPECT_FALSE(fs::exists(dir / "o.csv"));
}

TEST(CarelessCalls, UnknownCommandAndUnknownOptionAreNamed) {
  const auto r = test::run_moa("foo");
  EXPECT_EQ(r.exit_code, cli::kExitUsage);
  EXPECT_THAT(r.err, HasSubstr("unknown command 'foo'"));
  const auto s = test::run_moa("odometry --bogus");
  EXPECT_EQ(s.exit_code, cli::kExitUsage);
  EXPECT_THAT(s.err, HasSubstr("unknown option or argument '--bogus'"));
  // A missing --method is a usage error too, before anything is read.
  const auto m =
      test::run_moa("calibrate --config " + kExample + "/robot.yaml --log " + kExample + " --out " +
                    (test::scratch_dir("careless-method") / "c.yaml").string());
  EXPECT_EQ(m.exit_code, cli::kExitUsage) << m.err;
  EXPECT_THAT(m.err, HasSubstr("--method"));
}

TEST(CarelessCalls, ExitCodesAreDocumentedInHelp) {
  const auto r = test::run_moa("--help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_THAT(r.out, HasSubstr("Exit codes: 0 success, 1 bad input"));
  const auto m = test::run_moa("odometry --config " + kExample +
                               "/robot.yaml --log /no/such/dir "
                               "--out /tmp/x.csv");
  EXPECT_EQ(m.exit_code, cli::kExitUsage);  // CLI11's existence check: a usage error
  const auto missing = test::scratch_dir("careless-io");
  const auto w = test::run_moa(
      odometry(fs::path(kExample), "--out " + (missing / "no-dir" / "o.csv").string()));
  EXPECT_EQ(w.exit_code, cli::kExitIo) << w.err;
}

}  // namespace
}  // namespace moa
