// struct input_event bytes through io::EvdevDecoder, fed in two pieces split
// where the first byte says (a record may straddle reads).
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "moa/sources/evdev.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::span<const std::uint8_t> bytes(data + 1, size - 1);
  const std::size_t split = data[0] % (bytes.size() + 1);
  moa::io::EvdevDecoder decoder;
  std::vector<moa::io::EvdevFrame> frames;
  decoder.feed(bytes.first(split), frames);
  decoder.feed(bytes.subspan(split), frames);
  return 0;
}
