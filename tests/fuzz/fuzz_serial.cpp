// Bytes of a serial line through io::serial::Decoder, byte by byte, and the
// DATA frames it returns through DataTracker at the tick rate HELLO gave;
// a GYRO frame's rate must be finite and the frame must encode back to a
// frame that decodes to the same fields.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <optional>
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
    } else if (const auto* gyro = std::get_if<serial::Gyro>(message)) {
      if (!std::isfinite(gyro->rate())) std::abort();
      serial::Decoder again;
      std::optional<std::variant<serial::Message, serial::FrameError>> back;
      for (const std::uint8_t byte : serial::encode(*gyro)) back = again.push(byte);
      const auto* m = back ? std::get_if<serial::Message>(&*back) : nullptr;
      const auto* g = m ? std::get_if<serial::Gyro>(m) : nullptr;
      if (!g || g->sequence != gyro->sequence || g->sum != gyro->sum || g->n != gyro->n ||
          g->lsb_per_dps_x10 != gyro->lsb_per_dps_x10 || g->flags != gyro->flags) {
        std::abort();
      }
    }
  }
  return 0;
}
