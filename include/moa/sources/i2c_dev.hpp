// One device on a Linux I2C adapter through i2c-dev (/dev/i2c-N, module
// i2c-dev): each register read is one I2C_RDWR ioctl of two messages (the
// register address written, then the bytes read after a repeated start),
// each write one message of the address and the bytes.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

#include "moa/sources/i2c_transport.hpp"

namespace moa::io {

/// "/dev/i2c-1:0x17", or "/dev/i2c-1" with `default_address`: the path and
/// the 7-bit address (decimal or 0x hex, 0x03..0x77). Throws io::Error
/// naming `spec` for an empty path or an address that is not one.
struct I2cAddress {
  std::filesystem::path path;
  std::uint8_t address = 0;
};
I2cAddress parse_i2c_address(const std::string& spec, std::uint8_t default_address);

class I2cDev final : public I2cTransport {
 public:
  /// Opens the adapter read-write and checks that it can do combined
  /// transfers (I2C_FUNCS has I2C_FUNC_I2C). Throws io::IoError "PATH:
  /// cannot open (why)" (missing: is the module i2c-dev loaded?; permission:
  /// the group i2c), io::Error "PATH: not an I2C adapter".
  I2cDev(const std::filesystem::path& path, std::uint8_t address);
  ~I2cDev() override;
  I2cDev(const I2cDev&) = delete;
  I2cDev& operator=(const I2cDev&) = delete;

  int read(std::uint8_t reg, std::span<std::uint8_t> out) override;
  int write(std::uint8_t reg, std::span<const std::uint8_t> data) override;
  std::string where() const override;

 private:
  int fd_ = -1;
  std::filesystem::path path_;
  std::uint8_t address_;
};

}  // namespace moa::io
