// Careless calls and bad data that used to go wrong quietly: each is now
// refused at once with a message naming the option, file or line, and with
// the documented exit code (io/error.hpp ExitCode), and no output is left.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "moa/io/error.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

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
  EXPECT_EQ(r.exit_code, io::kExitBadInput);
  EXPECT_THAT(r.err, HasSubstr("--out " + (dir / "mice.csv").string() + ": is an input"));
  EXPECT_EQ(slurp(dir / "mice.csv"), before);
  // The same file by another spelling.
  const auto r2 = test::run_moa(odometry(dir, "--out " + (dir / "." / "robot.yaml").string()));
  EXPECT_EQ(r2.exit_code, io::kExitBadInput);
  EXPECT_THAT(r2.err, HasSubstr("is an input"));
}

TEST(CarelessCalls, NotANumberIsRefusedNamingTheOption) {
  const fs::path out = test::scratch_dir("careless-nan") / "o.csv";
  for (const std::string option : {"--rate", "--max-row-interval", "--alpha", "--e-th"}) {
    const auto r = test::run_moa("odometry --config " + kExample + "/robot.yaml --log " + kExample +
                                 " " + option + " nan --out " + out.string());
    EXPECT_EQ(r.exit_code, io::kExitUsage) << option;
    EXPECT_THAT(r.err, HasSubstr(option)) << option;
    EXPECT_THAT(r.err, HasSubstr("not a finite number")) << option << r.err;
  }
  const auto r = test::run_moa("odometry --config " + kExample + "/robot.yaml --log " + kExample +
                               " --initial-pose nan,0,0 --out " + out.string());
  EXPECT_EQ(r.exit_code, io::kExitUsage);
  EXPECT_THAT(r.err, HasSubstr("--initial-pose"));
  // Every subcommand's floating-point options, not only odometry's.
  const auto s = test::run_moa("evaluate --truth " + kExample + "/truth.csv --odometry " +
                               kExample + "/truth.csv --json");
  EXPECT_EQ(s.exit_code, 0) << s.err;
  EXPECT_FALSE(fs::exists(out));
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
  EXPECT_EQ(r.exit_code, io::kExitBadInput);
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
  EXPECT_EQ(r.exit_code, io::kExitBadInput);
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
  EXPECT_EQ(r.exit_code, io::kExitBadInput);
  EXPECT_THAT(r.err, HasSubstr("mice.csv:10: row at t = "));
  EXPECT_THAT(r.err, HasSubstr("far beyond what the sensor can track"));
  EXPECT_FALSE(fs::exists(dir / "o.csv"));
}

TEST(CarelessCalls, UnknownCommandAndUnknownOptionAreNamed) {
  const auto r = test::run_moa("foo");
  EXPECT_EQ(r.exit_code, io::kExitUsage);
  EXPECT_THAT(r.err, HasSubstr("unknown command 'foo'"));
  const auto s = test::run_moa("odometry --bogus");
  EXPECT_EQ(s.exit_code, io::kExitUsage);
  EXPECT_THAT(s.err, HasSubstr("unknown option or argument '--bogus'"));
}

TEST(CarelessCalls, ExitCodesAreDocumentedInHelp) {
  const auto r = test::run_moa("--help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_THAT(r.out, HasSubstr("Exit codes: 0 success, 1 bad input"));
  const auto m = test::run_moa("odometry --config " + kExample +
                               "/robot.yaml --log /no/such/dir "
                               "--out /tmp/x.csv");
  EXPECT_EQ(m.exit_code, io::kExitUsage);  // CLI11's existence check: a usage error
  const auto missing = test::scratch_dir("careless-io");
  const auto w = test::run_moa(
      odometry(fs::path(kExample), "--out " + (missing / "no-dir" / "o.csv").string()));
  EXPECT_EQ(w.exit_code, io::kExitIo) << w.err;
}

}  // namespace
}  // namespace moa
