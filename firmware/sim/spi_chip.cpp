#include "spi_chip.hpp"

#include <cstdio>

namespace moa::firmware_sim {

void SpiChip::violation(double t_us, const std::string& what) {
  char at[32];
  std::snprintf(at, sizeof at, "t=%.2f us: ", t_us);
  violations_.push_back(at + what);
}

std::string SpiChip::hex(std::uint8_t value) {
  char text[8];
  std::snprintf(text, sizeof text, "0x%02x", value);
  return text;
}

}  // namespace moa::firmware_sim
