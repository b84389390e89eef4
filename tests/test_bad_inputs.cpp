// The bad-input suite: every case of tests/data/bad/cases.txt through the
// built `moa`, its exit code and its whole stderr exact, nothing written,
// each within 15 s, 1 GB of memory and 50 MB a file (issue #28).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa {
namespace {

namespace fs = std::filesystem;

struct BadInput {
  std::string name;
  int exit_code = 0;
  std::string args;
  std::string err;  ///< '|' separates lines
};

std::string trim(const std::string& s) {
  const auto first = s.find_first_not_of(' ');
  const auto last = s.find_last_not_of(' ');
  return first == std::string::npos ? "" : s.substr(first, last - first + 1);
}

std::vector<BadInput> read_cases() {
  std::ifstream in(std::string(MOA_TEST_DATA_DIR) + "/bad/cases.txt");
  std::vector<BadInput> cases;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line.front() == '#') continue;
    const auto a = line.find(" | ");
    const auto b = line.find(" | ", a + 3);
    const auto c = line.find(" | ", b + 3);
    if (a == std::string::npos || b == std::string::npos || c == std::string::npos) {
      cases.push_back({"malformed_manifest_line", -2, line, ""});
      continue;
    }
    BadInput k;
    k.name = trim(line.substr(0, a));
    for (char& ch : k.name) {
      if (ch == '-') ch = '_';
    }
    k.exit_code = std::stoi(line.substr(a + 3, b - a - 3));
    k.args = line.substr(b + 3, c - b - 3);
    k.err = line.substr(c + 3);
    cases.push_back(k);
  }
  return cases;
}

std::string substitute(std::string text, const std::string& key, const std::string& value) {
  for (auto at = text.find(key); at != std::string::npos; at = text.find(key, at + value.size())) {
    text.replace(at, key.size(), value);
  }
  return text;
}

class BadInputs : public ::testing::TestWithParam<BadInput> {};

TEST_P(BadInputs, RefusedWithTheExactMessageAndNothingWritten) {
  const BadInput& k = GetParam();
  ASSERT_NE(k.exit_code, -2) << "cases.txt: not NAME | EXIT | ARGUMENTS | STDERR: " << k.args;
  const fs::path out = test::scratch_dir("bad-input");
  const auto fill = [&](std::string text) {
    text = substitute(std::move(text), "{bad}", std::string(MOA_TEST_DATA_DIR) + "/bad");
    text = substitute(std::move(text), "{examples}", std::string(MOA_SOURCE_DIR) + "/examples");
    return substitute(std::move(text), "{out}", out.string());
  };
  // Every case within the limits of issue #28: 15 s, 1 GB, 50 MB a file.
  const auto r = test::run_moa_bounded(fill(k.args));
  EXPECT_EQ(test::limits_exceeded(r), "");
  EXPECT_EQ(r.exit_code, k.exit_code);
  EXPECT_EQ(r.err, substitute(fill(k.err), "|", "\n") + "\n");
  EXPECT_TRUE(fs::is_empty(out)) << "an output was written";
}

INSTANTIATE_TEST_SUITE_P(Cases, BadInputs, ::testing::ValuesIn(read_cases()),
                         [](const auto& param_info) { return param_info.param.name; });

}  // namespace
}  // namespace moa
