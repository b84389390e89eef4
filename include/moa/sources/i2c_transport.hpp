// Register reads and writes of one I2C device: the seam between a device's
// register protocol (sources/otos_unit.hpp) and the bus. Linux i2c-dev
// implements it (sources/i2c_dev.hpp); a test stands in with a register
// model. Errors come back as values (an errno number), never as
// exceptions: a device that stops answering mid-run is data, not a crash.
#pragma once

#include <cstdint>
#include <span>
#include <string>

namespace moa::io {

class I2cTransport {
 public:
  virtual ~I2cTransport() = default;
  /// Reads out.size() bytes from consecutive registers starting at `reg`
  /// (one combined transfer: the register address written, a repeated
  /// start, the bytes read). 0, or an errno value (EREMOTEIO: no
  /// acknowledge, ETIMEDOUT, EIO ...); `out` is unspecified then.
  virtual int read(std::uint8_t reg, std::span<std::uint8_t> out) = 0;
  /// Writes `data` to consecutive registers starting at `reg`. 0 or errno.
  virtual int write(std::uint8_t reg, std::span<const std::uint8_t> data) = 0;
  /// For messages: "/dev/i2c-1:0x17".
  virtual std::string where() const = 0;
};

}  // namespace moa::io
