// Bytes of a serial line through io::serial::Decoder, byte by byte, and the
// DATA frames it returns through DataTracker at the tick rate HELLO gave.
#include <cstddef>
#include <cstdint>
#include <variant>

#include "moa/sources/serial_protocol.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace serial = moa::io::serial;
  serial::Decoder decoder;
  serial::DataTracker tracker;
  std::uint32_t tick_hz = 1000;
  for (std::size_t i = 0; i < size; ++i) {
    const auto result = decoder.push(data[i]);
    if (!result) continue;
    const auto* message = std::get_if<serial::Message>(&*result);
    if (!message) continue;
    if (const auto* hello = std::get_if<serial::Hello>(message)) {
      if (hello->tick_hz > 0) tick_hz = hello->tick_hz;
    } else if (const auto* frame = std::get_if<serial::Data>(message)) {
      (void)tracker.accept(*frame, tick_hz);
    }
  }
  return 0;
}
