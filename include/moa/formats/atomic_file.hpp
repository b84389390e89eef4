// An output file that appears whole or not at all: written to a temporary
// file beside the target and renamed over it by commit(). On Linux the
// temporary has no name until commit() (O_TMPFILE), so even SIGKILL leaves
// nothing behind; elsewhere it is a hidden file. Destroyed without commit()
// (an error, an exception), the temporary is removed; so it is on SIGINT or
// SIGTERM in `moa` (io/cleanup.hpp).
#pragma once

#include <filesystem>
#include <fstream>

#include "moa/formats/cleanup.hpp"

namespace moa::io {

class AtomicFile {
 public:
  /// Opens the temporary file; throws io::Error naming the path if it cannot.
  explicit AtomicFile(std::filesystem::path target);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  std::ostream& stream() { return out_; }
  /// Starts writing what the stream holds so far to the disk, without
  /// waiting for it (Linux: sync_file_range), so that commit()'s fsync has
  /// less left to wait for. Optional; failures are left for commit() to see.
  void start_writeback();
  /// Flushes, closes and renames onto the target; throws io::Error on failure.
  void commit();

 private:
  void close_writeback();

  std::filesystem::path target_;
  std::filesystem::path temp_;
  TemporaryPath registered_;
  std::ofstream out_;
  int writeback_fd_ = -1;  ///< the temporary, opened by start_writeback()
  int anonymous_fd_ = -1;  ///< the unnamed temporary (O_TMPFILE), until commit()
  bool committed_ = false;
};

}  // namespace moa::io
