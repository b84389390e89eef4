// An evemu recording through io::EvemuReader.
// Any exception but io::Error, any sanitizer report, is a finding.
#include <cstddef>
#include <cstdint>

#include "fuzz_input.hpp"
#include "moa/formats/error.hpp"
#include "moa/sources/evemu.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto file = moa::fuzz::input_file("m1.events", data, size);
  try {
    moa::io::EvemuReader reader({{"m1", file}});
    (void)reader.start_time();
    while (reader.next()) {
    }
  } catch (const moa::io::Error&) {
  }
  return 0;
}
