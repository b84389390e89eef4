#include "option_flags.hpp"

namespace moa::cli {

std::string flag_of(std::string_view option) {
  std::string flag = "--";
  for (const char c : option) flag += (c == '_' || c == '.') ? '-' : c;
  return flag;
}

std::string with_flags(const io::OptionError& error) { return error.render(flag_of); }

}  // namespace moa::cli
