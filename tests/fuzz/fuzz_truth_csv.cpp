// truth.csv through io::RowReader<io::TruthRow>.
// Any exception but io::Error, any sanitizer report, is a finding.
#include <cstddef>
#include <cstdint>

#include "fuzz_input.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/log.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto file = moa::fuzz::input_file("truth.csv", data, size);
  try {
    moa::io::RowReader<moa::io::TruthRow> reader(file);
    while (reader.next()) {
    }
  } catch (const moa::io::Error&) {
  }
  return 0;
}
