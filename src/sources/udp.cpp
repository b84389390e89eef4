#include "moa/sources/udp.hpp"

#include <fmt/core.h>
#include <netdb.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cstring>

#include "moa/formats/error.hpp"

namespace moa::io {

std::optional<UdpAddress> parse_udp_address(std::string_view text, std::string_view flag) {
  constexpr std::string_view kScheme = "udp:";
  if (text.substr(0, kScheme.size()) != kScheme) return std::nullopt;
  std::string_view rest = text.substr(kScheme.size());
  UdpAddress address;
  if (const auto colon = rest.rfind(':'); colon != std::string_view::npos) {
    address.host = std::string(rest.substr(0, colon));
    rest = rest.substr(colon + 1);
  }
  int port = 0;
  const auto [end, ec] = std::from_chars(rest.data(), rest.data() + rest.size(), port);
  if (address.host.empty() || ec != std::errc() || end != rest.data() + rest.size() || port < 1 ||
      port > 65535) {
    throw Error(fmt::format("{} {}: expected udp:[HOST:]PORT, PORT in 1..65535", flag, text));
  }
  address.port = std::string(rest);
  return address;
}

int open_udp_socket(const UdpAddress& address, bool bind, std::string_view flag) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_DGRAM;
  hints.ai_flags = bind ? AI_PASSIVE : 0;
  addrinfo* found = nullptr;
  if (const int rc = ::getaddrinfo(address.host.c_str(), address.port.c_str(), &hints, &found);
      rc != 0) {
    throw Error(
        fmt::format("{} udp:{}:{}: {}", flag, address.host, address.port, ::gai_strerror(rc)));
  }
  int fd = -1;
  int error = 0;
  for (addrinfo* a = found; a != nullptr && fd < 0; a = a->ai_next) {
    fd = ::socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC, a->ai_protocol);
    if (fd < 0) {
      error = errno;
      continue;
    }
    if ((bind ? ::bind(fd, a->ai_addr, a->ai_addrlen) : ::connect(fd, a->ai_addr, a->ai_addrlen)) !=
        0) {
      error = errno;
      ::close(fd);
      fd = -1;
    }
  }
  ::freeaddrinfo(found);
  if (fd < 0) {
    throw Error(fmt::format("{} udp:{}:{}: cannot {} ({})", flag, address.host, address.port,
                            bind ? "bind" : "connect", std::strerror(error)));
  }
  return fd;
}

}  // namespace moa::io
