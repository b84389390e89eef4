#include "moa/formats/mice_writer.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <optional>

#include "moa/formats/atomic_file.hpp"
#include "moa/formats/csv.hpp"
#include "moa/formats/error.hpp"

#if defined(__unix__) || defined(__APPLE__)
#include <fcntl.h>
#include <unistd.h>
#endif

namespace moa::io {
namespace {

// Counts are exact in a double only up to 2^53 (the reader's limit too).
constexpr double kMaxExactCount = 9007199254740992.0;

bool valid_count(double value) {
  return std::isfinite(value) && std::abs(value) <= kMaxExactCount && value == std::floor(value);
}

void sync_to_disk(const std::filesystem::path& file) {
#if defined(__unix__) || defined(__APPLE__)
  const int fd = ::open(file.c_str(), O_RDONLY);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
#else
  (void)file;
#endif
}

}  // namespace

struct MiceWriter::Impl {
  std::string file_name;
  std::filesystem::path target;
  std::filesystem::path partial;
  std::vector<std::string> names;
  bool quality = false;
  std::optional<AtomicFile> atomic;  // kWholeOrNothing
  std::ofstream journal;             // kJournal
  std::ostream* out = nullptr;
  fmt::memory_buffer line;
  std::optional<double> last_t;
  std::size_t rows = 0;
  bool committed = false;

  [[noreturn]] void fail(std::string_view what) const {
    throw Error(printable(fmt::format("{}: {}", file_name, what)));
  }
};

MiceWriter::MiceWriter(const std::filesystem::path& file, std::vector<std::string> names,
                       bool quality_columns, Durability durability,
                       const std::vector<std::string>& comments)
    : impl_(std::make_unique<Impl>()) {
  Impl& impl = *impl_;
  impl.file_name = file.string();
  impl.target = file;
  impl.names = std::move(names);
  impl.quality = quality_columns;
  for (const auto& name : impl.names) {
    // Readers trim fields and split at commas: such a name would not read back.
    if (name.empty() || name.find_first_of(",\r\n \t") != std::string::npos || name[0] == '#') {
      impl.fail(fmt::format("invalid sensor name '{}'", name));
    }
  }
  if (durability == Durability::kWholeOrNothing) {
    impl.atomic.emplace(file);
    impl.out = &impl.atomic->stream();
    impl.partial = file;
  } else {
    impl.partial = std::filesystem::path(file.string() + ".part");
    impl.journal.open(impl.partial, std::ios::binary | std::ios::trunc);
    if (!impl.journal) {
      const int error = errno;
      throw Error(fmt::format("{}: cannot open for writing ({})", impl.partial.string(),
                              error != 0 ? std::strerror(error) : "unknown error"));
    }
    impl.out = &impl.journal;
  }
  for (const auto& comment : comments) {
    if (comment.find_first_of("\r\n") != std::string::npos) impl.fail("comment with a line break");
    *impl.out << "# " << comment << '\n';
  }
  *impl.out << (impl.quality ? "t,sensor,dx,dy,squal,flags\n" : "t,sensor,dx,dy\n");
}

MiceWriter::~MiceWriter() = default;

void MiceWriter::write(const SensorRow& row) {
  Impl& impl = *impl_;
  if (impl.committed) impl.fail("write after commit");
  if (row.sensor < 0 || static_cast<std::size_t>(row.sensor) >= impl.names.size()) {
    impl.fail(fmt::format("row at t={}: no sensor with index {}", row.t, row.sensor));
  }
  if (!std::isfinite(row.t)) impl.fail(fmt::format("row time is not finite ({})", row.t));
  if (impl.last_t && row.t < *impl.last_t) {
    impl.fail(fmt::format("time goes backwards ({} after {})", row.t, *impl.last_t));
  }
  if (!valid_count(row.counts.x()) || !valid_count(row.counts.y())) {
    impl.fail(fmt::format("row at t={}: counts ({}, {}) are not integers within 2^53", row.t,
                          row.counts.x(), row.counts.y()));
  }
  impl.last_t = row.t;
  impl.line.clear();
  // "{}" of a double is the shortest text that reads back as the same value.
  fmt::format_to(std::back_inserter(impl.line), "{},{},{},{}", row.t,
                 impl.names[static_cast<std::size_t>(row.sensor)],
                 static_cast<std::int64_t>(row.counts.x()),
                 static_cast<std::int64_t>(row.counts.y()));
  if (impl.quality) {
    if (row.squal) {
      fmt::format_to(std::back_inserter(impl.line), ",{},{}", *row.squal, row.flags);
    } else {
      fmt::format_to(std::back_inserter(impl.line), ",,{}", row.flags);
    }
  }
  impl.line.push_back('\n');
  impl.out->write(impl.line.data(), static_cast<std::streamsize>(impl.line.size()));
  ++impl.rows;
}

void MiceWriter::flush() {
  impl_->out->flush();
  if (!*impl_->out)
    impl_->fail(fmt::format("cannot write ({})", std::strerror(errno ? errno : EIO)));
}

void MiceWriter::commit() {
  Impl& impl = *impl_;
  if (impl.committed) impl.fail("already committed");
  if (impl.atomic) {
    impl.atomic->commit();
  } else {
    impl.journal.flush();
    const bool written = static_cast<bool>(impl.journal);
    impl.journal.close();
    if (!written || !impl.journal) {
      impl.fail(fmt::format("cannot write ({})", std::strerror(errno ? errno : EIO)));
    }
    sync_to_disk(impl.partial);
    std::error_code ec;
    std::filesystem::rename(impl.partial, impl.target, ec);
    if (ec) impl.fail(fmt::format("cannot rename {} ({})", impl.partial.string(), ec.message()));
  }
  impl.committed = true;
}

std::size_t MiceWriter::rows() const { return impl_->rows; }

const std::filesystem::path& MiceWriter::partial_path() const { return impl_->partial; }

}  // namespace moa::io
