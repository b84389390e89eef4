// Robot config YAML through io::parse_config; a config it accepts must be
// written by format_config and read back to the same text.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <optional>
#include <string_view>

#include "moa/formats/config.hpp"
#include "moa/formats/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  std::optional<moa::io::RobotConfig> config;
  try {
    config = moa::io::parse_config(text, "fuzz.yaml");
  } catch (const moa::io::Error&) {
    return 0;
  }
  const std::string once = moa::io::format_config(*config);
  if (moa::io::format_config(moa::io::parse_config(once, "formatted.yaml")) != once) std::abort();
  return 0;
}
