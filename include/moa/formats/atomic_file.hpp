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

  /// A file buffer that keeps the errno of its first failed write, which a
  /// std::ofstream forgets ("No space left on device" on a full disk).
  class Buffer : public std::filebuf {
   public:
    int error = 0;  ///< errno of the first failed write, 0 if none

   protected:
    int_type overflow(int_type c) override;
    std::streamsize xsputn(const char_type* s, std::streamsize n) override;
    int sync() override;

   private:
    void failed();
  };

  std::filesystem::path target_;
  std::filesystem::path temp_;
  TemporaryPath registered_;
  Buffer buffer_;
  std::ostream out_{&buffer_};
  int writeback_fd_ = -1;  ///< the temporary, opened by start_writeback()
  int anonymous_fd_ = -1;  ///< the unnamed temporary (O_TMPFILE), until commit()
  bool committed_ = false;
};

}  // namespace moa::io
