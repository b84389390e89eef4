#include "moa/sources/i2c_dev.hpp"

#include <fcntl.h>
#include <fmt/core.h>
#include <linux/i2c-dev.h>
#include <linux/i2c.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cstring>
#include <vector>

#include "moa/formats/error.hpp"

namespace moa::io {

I2cAddress parse_i2c_address(const std::string& spec, std::uint8_t default_address) {
  I2cAddress out;
  out.address = default_address;
  const std::size_t colon = spec.rfind(':');
  std::string path = spec;
  if (colon != std::string::npos) {
    path = spec.substr(0, colon);
    const std::string text = spec.substr(colon + 1);
    const bool hex = text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X');
    const char* begin = text.data() + (hex ? 2 : 0);
    const char* end = text.data() + text.size();
    unsigned value = 0;
    const auto [ptr, ec] = std::from_chars(begin, end, value, hex ? 16 : 10);
    if (text.empty() || ec != std::errc() || ptr != end || value < 0x03 || value > 0x77) {
      throw Error(fmt::format(
          "{}: '{}' is not a 7-bit I2C address (0x03 to 0x77, decimal or 0x hex)", spec, text));
    }
    out.address = static_cast<std::uint8_t>(value);
  }
  if (path.empty()) throw Error(fmt::format("{}: no device path (/dev/i2c-N)", spec));
  out.path = path;
  return out;
}

I2cDev::I2cDev(const std::filesystem::path& path, std::uint8_t address)
    : path_(path), address_(address) {
  fd_ = ::open(path.c_str(), O_RDWR | O_CLOEXEC);
  if (fd_ < 0) {
    const int e = errno;
    throw IoError(fmt::format("{}: cannot open ({}){}", path.string(), std::strerror(e),
                              e == ENOENT
                                  ? "; is the i2c-dev module loaded (sudo modprobe i2c-dev)? see "
                                    "docs/hardware.md"
                              : e == EACCES ? "; add yourself to the group i2c (docs/hardware.md)"
                                            : ""));
  }
  unsigned long funcs = 0;
  if (::ioctl(fd_, I2C_FUNCS, &funcs) < 0) {
    const int e = errno;
    ::close(fd_);
    throw Error(
        fmt::format("{}: not an I2C adapter (I2C_FUNCS: {})", path.string(), std::strerror(e)));
  }
  if ((funcs & I2C_FUNC_I2C) == 0) {
    ::close(fd_);
    throw Error(fmt::format(
        "{}: the adapter cannot do combined I2C transfers (I2C_FUNC_I2C), which reading an "
        "OTOS's registers needs",
        path.string()));
  }
}

I2cDev::~I2cDev() {
  if (fd_ >= 0) ::close(fd_);
}

int I2cDev::read(std::uint8_t reg, std::span<std::uint8_t> out) {
  std::uint8_t address_byte = reg;
  i2c_msg messages[2] = {};
  messages[0].addr = address_;
  messages[0].flags = 0;
  messages[0].len = 1;
  messages[0].buf = &address_byte;
  messages[1].addr = address_;
  messages[1].flags = I2C_M_RD;
  messages[1].len = static_cast<__u16>(out.size());
  messages[1].buf = out.data();
  i2c_rdwr_ioctl_data transfer{messages, 2};
  if (::ioctl(fd_, I2C_RDWR, &transfer) < 0) return errno != 0 ? errno : EIO;
  return 0;
}

int I2cDev::write(std::uint8_t reg, std::span<const std::uint8_t> data) {
  std::vector<std::uint8_t> buffer(data.size() + 1);
  buffer[0] = reg;
  std::copy(data.begin(), data.end(), buffer.begin() + 1);
  i2c_msg message{};
  message.addr = address_;
  message.flags = 0;
  message.len = static_cast<__u16>(buffer.size());
  message.buf = buffer.data();
  i2c_rdwr_ioctl_data transfer{&message, 1};
  if (::ioctl(fd_, I2C_RDWR, &transfer) < 0) return errno != 0 ? errno : EIO;
  return 0;
}

std::string I2cDev::where() const { return fmt::format("{}:0x{:02x}", path_.string(), address_); }

}  // namespace moa::io
