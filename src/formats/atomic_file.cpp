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

void AtomicFile::Buffer::failed() {
  if (error == 0) error = errno != 0 ? errno : EIO;
}

AtomicFile::Buffer::int_type AtomicFile::Buffer::overflow(int_type c) {
  errno = 0;
  const int_type r = std::filebuf::overflow(c);
  if (traits_type::eq_int_type(r, traits_type::eof())) failed();
  return r;
}

std::streamsize AtomicFile::Buffer::xsputn(const char_type* s, std::streamsize n) {
  errno = 0;
  const std::streamsize r = std::filebuf::xsputn(s, n);
  if (r < n) failed();
  return r;
}

int AtomicFile::Buffer::sync() {
  errno = 0;
  const int r = std::filebuf::sync();
  if (r != 0) failed();
  return r;
}

AtomicFile::AtomicFile(std::filesystem::path target) : target_(std::move(target)) {
#if defined(__linux__) && defined(O_TMPFILE)
  // A file without a name in the target's directory (Linux, O_TMPFILE): a
  // run killed by SIGKILL leaves nothing behind. Written through
  // /proc/self/fd, which reopens it.
  const std::filesystem::path dir =
      target_.parent_path().empty() ? std::filesystem::path(".") : target_.parent_path();
  anonymous_fd_ = ::open(dir.c_str(), O_TMPFILE | O_WRONLY | O_CLOEXEC, 0666);
  if (anonymous_fd_ >= 0) {
    if (buffer_.open(fmt::format("/proc/self/fd/{}", anonymous_fd_),
                     std::ios::out | std::ios::binary | std::ios::trunc) == nullptr) {
      ::close(anonymous_fd_);
      anonymous_fd_ = -1;
    }
  }
#endif
  if (anonymous_fd_ < 0) {
    // Elsewhere, a hidden named temporary, removed on SIGINT and SIGTERM.
    temp_ = temporary_beside(target_);
    registered_ = TemporaryPath(temp_);
    (void)buffer_.open(temp_, std::ios::out | std::ios::binary | std::ios::trunc);
  }
  if (!buffer_.is_open()) {
    const int error = errno;
    throw IoError(fmt::format("{}: cannot open for writing ({})", target_.string(),
                              error != 0 ? std::strerror(error) : "unknown error"));
  }
}

AtomicFile::~AtomicFile() {
  close_writeback();
  if (committed_) return;
  buffer_.close();
#if defined(__unix__) || defined(__APPLE__)
  if (anonymous_fd_ >= 0) ::close(anonymous_fd_);
#endif
  if (temp_.empty()) return;
  std::error_code ignored;
  std::filesystem::remove(temp_, ignored);
  registered_.release();
}

void AtomicFile::start_writeback() {
#if defined(__linux__)
  out_.flush();
  if (anonymous_fd_ >= 0) {
    (void)::sync_file_range(anonymous_fd_, 0, 0, SYNC_FILE_RANGE_WRITE);
    return;
  }
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
  const bool written = static_cast<bool>(out_) && buffer_.close() != nullptr;
  if (!written) {
    // The first failed write's errno: "No space left on device" on a full
    // disk, however long the run went on after it.
    const int error = buffer_.error != 0 ? buffer_.error : (errno != 0 ? errno : EIO);
    throw IoError(fmt::format("{}: cannot write ({})", target_.string(), std::strerror(error)));
  }
#if defined(__linux__) && defined(O_TMPFILE)
  if (anonymous_fd_ >= 0) {
    // Data first, then a name: linked under a hidden name (registered for
    // SIGINT and SIGTERM for the moment it exists) and renamed onto the
    // target, which it replaces atomically.
    if (::fsync(anonymous_fd_) != 0) {
      throw IoError(fmt::format("{}: cannot write ({})", target_.string(), std::strerror(errno)));
    }
    temp_ = temporary_beside(target_);
    registered_ = TemporaryPath(temp_);
    const std::string self = fmt::format("/proc/self/fd/{}", anonymous_fd_);
    if (::linkat(AT_FDCWD, self.c_str(), AT_FDCWD, temp_.c_str(), AT_SYMLINK_FOLLOW) != 0) {
      const int error = errno;
      registered_.release();
      temp_.clear();
      throw IoError(fmt::format("{}: cannot write ({})", target_.string(), std::strerror(error)));
    }
    ::close(anonymous_fd_);
    anonymous_fd_ = -1;
  } else if (!sync_to_disk(temp_)) {
    throw IoError(fmt::format("{}: cannot write ({})", target_.string(), std::strerror(errno)));
  }
#else
  if (!sync_to_disk(temp_)) {
    throw IoError(fmt::format("{}: cannot write ({})", target_.string(), std::strerror(errno)));
  }
#endif
  std::error_code ec;
  std::filesystem::rename(temp_, target_, ec);
  if (ec) throw IoError(fmt::format("{}: cannot write ({})", target_.string(), ec.message()));
  registered_.release();
  committed_ = true;
}

}  // namespace moa::io
