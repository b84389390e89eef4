// Temporary files and directories that an interrupted run must not leave
// behind. io::AtomicFile registers its temporary file here for its
// lifetime; `moa` installs the handlers at start. On SIGINT, SIGTERM or any
// other signal that ends a process by default (SIGHUP, SIGQUIT, SIGPIPE,
// SIGALRM, SIGUSR1, SIGUSR2, SIGXCPU, SIGXFSZ, SIGVTALRM, SIGPROF; not the
// program's own faults, nor SIGKILL) the handler removes every registered
// path (newest first: a directory's files before the directory), writes one
// line to stderr ("moa: interrupted by SIGHUP; temporary files removed")
// and ends the process with 128 + the signal number (129, 130, 143, ...). A
// signal that was ignored when moa started (nohup) stays ignored. It does only async-signal-safe
// work (unlink, rmdir, write, _exit) on a fixed table of paths filled
// before the signal.
#pragma once

#include <filesystem>

namespace moa::io {

/// Registers `path` for removal on a signal (above) while this object lives.
/// Paths beyond the table's 256 entries, or longer than 4095 bytes, are not
/// registered (they would be left behind by a signal, as without this).
class TemporaryPath {
 public:
  TemporaryPath() = default;
  explicit TemporaryPath(const std::filesystem::path& path);
  ~TemporaryPath();
  TemporaryPath(TemporaryPath&& other) noexcept;
  TemporaryPath& operator=(TemporaryPath&& other) noexcept;
  TemporaryPath(const TemporaryPath&) = delete;
  TemporaryPath& operator=(const TemporaryPath&) = delete;

  /// Stops watching the path (it was renamed into place or removed).
  void release();

 private:
  int slot_ = -1;
};

/// Installs the handlers described above.
void remove_temporaries_on_signal();

}  // namespace moa::io
