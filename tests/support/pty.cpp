#include "support/pty.hpp"

#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <stdexcept>
#include <variant>

#include "moa/sources/serial_protocol.hpp"

namespace moa::test {

PseudoTerminal::PseudoTerminal() {
  char name[256] = {};
  termios raw{};
  ::cfmakeraw(&raw);
  if (::openpty(&master_, &slave_, name, &raw, nullptr) != 0) {
    throw std::runtime_error("openpty failed");
  }
  device_ = name;
  // A program the test starts must not inherit the master: holding it open
  // would keep the line up after close_master().
  ::fcntl(master_, F_SETFD, FD_CLOEXEC);
  ::fcntl(slave_, F_SETFD, FD_CLOEXEC);
}

PseudoTerminal::~PseudoTerminal() {
  close_master();
  if (slave_ >= 0) ::close(slave_);
}

void PseudoTerminal::write(const std::vector<std::uint8_t>& bytes) const {
  std::size_t at = 0;
  while (at < bytes.size()) {
    const ssize_t n = ::write(master_, bytes.data() + at, bytes.size() - at);
    if (n <= 0) throw std::runtime_error("write to pty master failed");
    at += static_cast<std::size_t>(n);
  }
}

bool PseudoTerminal::wait_for_hello_request(double timeout) const {
  using Clock = std::chrono::steady_clock;
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                           std::chrono::duration<double>(timeout));
  io::serial::Decoder decoder;
  while (Clock::now() < deadline) {
    pollfd p{master_, POLLIN, 0};
    if (::poll(&p, 1, 20) <= 0) continue;
    std::uint8_t buffer[256];
    const ssize_t n = ::read(master_, buffer, sizeof buffer);
    if (n <= 0) continue;
    for (ssize_t i = 0; i < n; ++i) {
      const auto out = decoder.push(buffer[i]);
      if (!out) continue;
      const auto* message = std::get_if<io::serial::Message>(&*out);
      if (message && std::holds_alternative<io::serial::HelloRequest>(*message)) return true;
    }
  }
  return false;
}

void PseudoTerminal::close_master() {
  if (master_ >= 0) ::close(master_);
  master_ = -1;
}

}  // namespace moa::test
