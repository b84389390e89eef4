#include "moa/formats/read_file.hpp"

#include <fmt/format.h>

#include <cstdio>
#include <memory>

#include "moa/formats/error.hpp"

namespace moa::io {

std::string read_bounded(const std::filesystem::path& path, std::size_t max_bytes,
                         std::string_view what) {
  const std::string name = path.string();
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    throw IoError(fmt::format("{}: cannot open (is a directory)", name));
  }
  struct Close {
    void operator()(std::FILE* f) const { std::fclose(f); }
  };
  const std::unique_ptr<std::FILE, Close> in(std::fopen(path.c_str(), "rb"));
  if (!in) throw IoError(fmt::format("{}: cannot open", name));
  std::string text;
  char block[1 << 16];
  while (true) {
    const std::size_t n = std::fread(block, 1, sizeof block, in.get());
    if (n == 0) {
      if (std::ferror(in.get())) throw IoError(fmt::format("{}: read error", name));
      return text;
    }
    if (n > max_bytes - text.size()) {
      throw Error(fmt::format("{}: larger than {} bytes: not {}", name, max_bytes, what));
    }
    text.append(block, n);
  }
}

}  // namespace moa::io
