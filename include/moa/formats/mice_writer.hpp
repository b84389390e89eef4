// Writes mice.csv of log format v1 (docs/formats/log.md) row by row: the
// output of `moa import-evemu` and of `moa live --record`.
//
// Columns t,sensor,dx,dy, then squal,flags when asked for (an empty squal
// field means "not reported"). t is written as the shortest text that reads
// back as the same double, so a log replays to exactly the rows written.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "moa/core/synchronise.hpp"

namespace moa::io {

class MiceWriter {
 public:
  enum class Durability {
    /// The file appears on commit() only; without commit nothing is left.
    kWholeOrNothing,
    /// Rows go to FILE.part (flushed by flush()), renamed to FILE on
    /// commit(). Without commit (a crash, a kill) FILE.part stays with
    /// every row up to the last flush: a recording is never thrown away.
    kJournal,
  };

  /// `names[i]` is the name written for row.sensor == i; `comments` become
  /// '#' lines before the header.
  MiceWriter(const std::filesystem::path& file, std::vector<std::string> names,
             bool quality_columns, Durability durability,
             const std::vector<std::string>& comments = {});
  ~MiceWriter();
  MiceWriter(const MiceWriter&) = delete;
  MiceWriter& operator=(const MiceWriter&) = delete;

  /// Throws io::Error for a sensor index without a name, a time that is not
  /// finite or earlier than the previous row's, counts that are not integers.
  void write(const SensorRow& row);
  /// Hands the rows written so far to the operating system.
  void flush();
  /// Completes the file (see Durability); throws io::Error on failure.
  void commit();

  std::size_t rows() const;
  /// Where rows are being written before commit(): FILE.part for kJournal,
  /// FILE itself for kWholeOrNothing (whose temporary is hidden).
  const std::filesystem::path& partial_path() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace moa::io
