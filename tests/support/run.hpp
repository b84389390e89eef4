// Runs the moa command line from tests and captures what it prints.
#pragma once

#include <filesystem>
#include <string>

namespace moa::test {

struct RunResult {
  int exit_code = -1;
  std::string out;  ///< stdout
  std::string err;  ///< stderr
};

/// Runs `moa ARGS` (ARGS as a shell-quoted string).
RunResult run_moa(const std::string& args);

/// The whole text of a file (empty if it cannot be read).
std::string read_text(const std::filesystem::path& file);

}  // namespace moa::test
