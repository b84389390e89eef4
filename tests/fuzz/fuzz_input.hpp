// For the libFuzzer targets of tests/fuzz/: the input as a file, for the
// readers that take a path. One directory per process, removed at exit.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>

namespace moa::fuzz {

class ScratchDir {
 public:
  // In memory where there is /dev/shm: a file rewritten on disk for every
  // input costs a flush (ext4 flushes a truncated file on close).
  ScratchDir() : path_(base() / ("moa-fuzz-" + std::to_string(::getpid()))) {
    std::filesystem::create_directories(path_);
  }
  ~ScratchDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  static std::filesystem::path base() {
    std::error_code ec;
    if (std::filesystem::is_directory("/dev/shm", ec)) return "/dev/shm";
    return std::filesystem::temp_directory_path();
  }
  std::filesystem::path path_;
};

/// Writes the input to NAME in this process's scratch directory; returns its path.
inline std::filesystem::path input_file(std::string_view name, const std::uint8_t* data,
                                        std::size_t size) {
  static const ScratchDir dir;
  const std::filesystem::path path = dir.path() / name;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}

}  // namespace moa::fuzz
