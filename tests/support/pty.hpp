// A pseudo-terminal standing in for a serial device in tests: the code under
// test opens device() like a real port; the test plays the microcontroller
// on the master side.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace moa::test {

class PseudoTerminal {
 public:
  /// openpty(); the slave starts raw so that no byte is changed before the
  /// reader sets the port up itself.
  PseudoTerminal();
  ~PseudoTerminal();
  PseudoTerminal(const PseudoTerminal&) = delete;
  PseudoTerminal& operator=(const PseudoTerminal&) = delete;

  /// Path of the slave side, e.g. /dev/pts/3.
  const std::string& device() const { return device_; }
  /// The test's own descriptor of the slave (for tcgetattr checks; never read).
  int slave_fd() const { return slave_; }

  /// Device -> host bytes (blocks while the host's input queue is full).
  void write(const std::vector<std::uint8_t>& bytes) const;
  /// Waits up to `timeout` s for a HELLO_REQUEST frame from the host.
  bool wait_for_hello_request(double timeout) const;
  /// The device goes away: the host sees a hang-up.
  void close_master();

 private:
  int master_ = -1;
  int slave_ = -1;
  std::string device_;
};

}  // namespace moa::test
