// UDP endpoints of `moa live`: the robot's streams in (--streams udp:...)
// and the pose stream out (--pose-out udp:...). An address is written
// "udp:[HOST:]PORT"; HOST defaults to 127.0.0.1 (the loopback: nothing is
// exposed to the network unless asked).
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace moa::io {

struct UdpAddress {
  std::string host = "127.0.0.1";
  std::string port;
};

/// The address of "udp:[HOST:]PORT", nullopt when `text` does not start with
/// "udp:". Throws io::Error naming `flag` for a "udp:" text without a port
/// in 1..65535.
std::optional<UdpAddress> parse_udp_address(std::string_view text, std::string_view flag);

/// A datagram socket bound to `address` (to receive), or connected to it (to
/// send: a refused send then reports ECONNREFUSED). Close-on-exec. Throws
/// io::Error naming `flag` when the host does not resolve or the socket
/// cannot be made.
int open_udp_socket(const UdpAddress& address, bool bind, std::string_view flag);

}  // namespace moa::io
