// The library names an option by its field (io::OptionError,
// runs/option_error.hpp); the CLI by its flag. One rule for every command:
// "--" and the field with '_' and '.' as '-' (push_x -> --push-x,
// self_calibration.gauge -> --self-calibration-gauge).
#pragma once

#include <string>
#include <string_view>

#include "moa/runs/option_error.hpp"

namespace moa::cli {

std::string flag_of(std::string_view option);

/// The error's message with the command's flags.
std::string with_flags(const io::OptionError& error);

}  // namespace moa::cli
