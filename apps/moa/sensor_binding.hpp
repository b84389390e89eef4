// NAME=TARGET arguments of the CLI (--sensor NAME=FILE, --mouse NAME=DEV).
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace moa::cli {

struct SensorBinding {
  std::string name;
  std::string target;
};

/// Splits each "NAME=TARGET" at its first '='. Throws io::Error naming
/// `flag` for a missing '=', an empty part, a name that a log could not hold
/// (spaces, commas, a leading '#') and a name given twice.
std::vector<SensorBinding> parse_bindings(const std::vector<std::string>& args,
                                          std::string_view flag);

}  // namespace moa::cli
