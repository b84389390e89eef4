#include "moa/formats/atomic_file.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <random>
#include <system_error>

#include "moa/formats/error.hpp"

#if defined(__unix__) || defined(__APPLE__)
#include <fcntl.h>
#include <unistd.h>
#endif

namespace moa::io {
namespace {

// Beside the target (same file system, so the rename is atomic), hidden, and
// with a random part so that two writers of the same target do not collide.
std::filesystem::path temporary_beside(const std::filesystem::path& target) {
  std::random_device random;
  const auto tag = (static_cast<std::uint64_t>(random()) << 32) ^ random();
  auto name = fmt::format(".{}.{:016x}.tmp", target.filename().string(), tag);
  return target.parent_path() / name;
}

// Without this a crash shortly after the rename can leave an empty target
// on some file systems: the rename may reach the disk before the data.
bool sync_to_disk(const std::filesystem::path& file) {
#if defined(__unix__) || defined(__APPLE__)
  const int fd = ::open(file.c_str(), O_RDONLY);
  if (fd < 0) return false;
  const bool ok = ::fsync(fd) == 0;
  ::close(fd);
  return ok;
#else
  (void)file;
  return true;
#endif
}

}  // namespace

AtomicFile::AtomicFile(std::filesystem::path target)
    : target_(std::move(target)), temp_(temporary_beside(target_)), registered_(temp_) {
  out_.open(temp_, std::ios::binary | std::ios::trunc);
  if (!out_) {
    const int error = errno;
    throw IoError(fmt::format("{}: cannot open for writing ({})", target_.string(),
                              error != 0 ? std::strerror(error) : "unknown error"));
  }
}

AtomicFile::~AtomicFile() {
  close_writeback();
  if (committed_) return;
  out_.close();
  std::error_code ignored;
  std::filesystem::remove(temp_, ignored);
  registered_.release();
}

void AtomicFile::start_writeback() {
#if defined(__linux__)
  out_.flush();
  if (writeback_fd_ < 0) writeback_fd_ = ::open(temp_.c_str(), O_RDONLY | O_CLOEXEC);
  if (writeback_fd_ >= 0) (void)::sync_file_range(writeback_fd_, 0, 0, SYNC_FILE_RANGE_WRITE);
#endif
}

void AtomicFile::close_writeback() {
#if defined(__unix__) || defined(__APPLE__)
  if (writeback_fd_ >= 0) ::close(writeback_fd_);
#endif
  writeback_fd_ = -1;
}

void AtomicFile::commit() {
  if (committed_) throw Error(fmt::format("{}: already committed", target_.string()));
  close_writeback();
  out_.flush();
  const bool written = static_cast<bool>(out_);
  out_.close();
  if (!written || !out_) {
    // errno of the failed write: "No space left on device" on a full disk.
    throw IoError(fmt::format("{}: cannot write ({})", target_.string(),
                              std::strerror(errno != 0 ? errno : EIO)));
  }
  if (!sync_to_disk(temp_)) {
    throw IoError(fmt::format("{}: cannot write ({})", target_.string(), std::strerror(errno)));
  }
  std::error_code ec;
  std::filesystem::rename(temp_, target_, ec);
  if (ec) throw IoError(fmt::format("{}: cannot write ({})", target_.string(), ec.message()));
  registered_.release();
  committed_ = true;
}

}  // namespace moa::io
