// mice.csv through io::MiceReader, against a two-sensor config (m1, m2).
// Any exception but io::Error, any sanitizer report, is a finding.
#include <cstddef>
#include <cstdint>

#include "fuzz_input.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/log.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const moa::io::RobotConfig config = moa::io::parse_config(
      "version: 1\nsensors:\n"
      "  - {name: m1, position: [0.1, 0], yaw: 0, cpi: 800}\n"
      "  - {name: m2, position: [-0.1, 0], yaw: 3.14159, cpi: 800}\n",
      "fuzz.yaml");
  const auto file = moa::fuzz::input_file("mice.csv", data, size);
  try {
    moa::io::MiceReader reader(file, config);
    (void)reader.start_time();
    while (reader.next()) {
    }
  } catch (const moa::io::Error&) {
  }
  return 0;
}
