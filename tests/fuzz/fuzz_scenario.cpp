// Scenario YAML through sim::parse_scenario; an accepted scenario's frame
// count and configs must be computable without error.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "moa/formats/config.hpp"
#include "moa/formats/error.hpp"
#include "moa/sim/scenario.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const moa::sim::Scenario scenario = moa::sim::parse_scenario(text, "fuzz.yaml");
    (void)scenario.frame_count();
    (void)moa::io::format_config(scenario.nominal);
    (void)moa::io::format_config(scenario.truth);
  } catch (const moa::io::Error&) {
  }
  return 0;
}
