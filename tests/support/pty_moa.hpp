// `moa ARGS` on a pseudo-terminal (its stdin, stdout and stderr), for the
// tests of what moa does for someone at a terminal: keys typed without
// Enter, Ctrl-C, output read as it comes.
#pragma once

#include <poll.h>
#include <pty.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace moa::test {

/// `moa ARGS` with its terminal on a pty that the test reads and types into.
class PtyMoa {
 public:
  using Clock = std::chrono::steady_clock;

  explicit PtyMoa(const std::vector<std::string>& args) {
    pid_ = forkpty(&master_, nullptr, nullptr, nullptr);
    if (pid_ == 0) {
      std::vector<char*> argv;
      static const std::string cli = MOA_CLI_PATH;
      argv.push_back(const_cast<char*>(cli.c_str()));
      for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
      argv.push_back(nullptr);
      execv(argv[0], argv.data());
      _exit(127);
    }
  }
  ~PtyMoa() {
    if (pid_ > 0 && status_ < 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
    if (master_ >= 0) close(master_);
  }
  /// Reads until `text` has appeared `count` times in all output, or the
  /// deadline; true if it did.
  bool wait_for(const std::string& text, int count, Clock::time_point deadline) {
    for (;;) {
      if (occurrences(text) >= count) return true;
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      if (left <= 0) return false;
      pollfd p{master_, POLLIN, 0};
      if (poll(&p, 1, static_cast<int>(left)) <= 0) return false;
      char buffer[4096];
      const ssize_t n = read(master_, buffer, sizeof buffer);
      if (n <= 0) return occurrences(text) >= count;  // the child is gone
      output_.append(buffer, static_cast<std::size_t>(n));
    }
  }
  void type(const std::string& keys) {
    ASSERT_EQ(write(master_, keys.data(), keys.size()), static_cast<ssize_t>(keys.size()));
  }
  int exit_code(double seconds) {
    const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                             std::chrono::duration<double>(seconds));
    while (status_ < 0 && Clock::now() < deadline) {
      wait_for("\x01never\x01", 1,
               std::min(deadline, Clock::now() + std::chrono::milliseconds(50)));
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        status_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      }
    }
    return status_;
  }
  int occurrences(const std::string& text) const {
    int n = 0;
    for (auto at = output_.find(text); at != std::string::npos; at = output_.find(text, at + 1)) {
      ++n;
    }
    return n;
  }
  const std::string& output() const { return output_; }

 private:
  int master_ = -1;
  pid_t pid_ = -1;
  int status_ = -1;
  std::string output_;
};

}  // namespace moa::test
