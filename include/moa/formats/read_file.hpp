// Internal to moa's I/O: the one way a whole file is read into memory (the
// robot config, scenarios), bounded whatever the file is: a regular file, a
// FIFO, /dev/zero or a device never makes moa read more than `max_bytes`.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>

namespace moa::io {

/// The bytes of `path`, read until its end; throws io::Error "FILE: larger
/// than N bytes: not WHAT" as soon as more than `max_bytes` were read (never
/// from stat(), which says nothing of FIFOs and devices), io::IoError "FILE:
/// cannot open" when it cannot be opened or is a directory.
std::string read_bounded(const std::filesystem::path& path, std::size_t max_bytes,
                         std::string_view what);

}  // namespace moa::io
