// Loopback HTTP for the dashboard's tests: a free port, a GET, the bytes of
// an event stream for a while, and `moa` running in the background.
#pragma once

#include <sys/types.h>

#include <string>

namespace moa::test {

/// A TCP (or UDP) port on 127.0.0.1 that was free a moment ago.
int free_port(bool udp = false);

struct HttpResponse {
  int status = 0;  ///< 0: no connection or no answer
  std::string headers;
  std::string body;  ///< de-chunked
};
/// GET http://127.0.0.1:PORT/PATH; reads for at most `seconds`, then
/// returns what came (a stream is cut there).
HttpResponse http_get(int port, const std::string& path, double seconds);

/// `moa ARGS` started in the background (stdout and stderr to files);
/// killed (SIGTERM) if still running when destroyed.
class BackgroundMoa {
 public:
  explicit BackgroundMoa(const std::string& args);
  ~BackgroundMoa();
  BackgroundMoa(const BackgroundMoa&) = delete;
  BackgroundMoa& operator=(const BackgroundMoa&) = delete;
  /// Waits up to `seconds` for the exit; the exit code, -1 if still running.
  int wait(double seconds);
  std::string err() const;
  std::string out() const;
  /// Sends `signal` (SIGINT: Ctrl-C) to moa if it is still running.
  void signal(int signal);

 private:
  pid_t pid_ = -1;
  int status_ = -1;
  std::string dir_;
};

/// Polls GET / until it answers 200 (true) or `seconds` pass (false).
bool wait_for_server(int port, double seconds);

}  // namespace moa::test
