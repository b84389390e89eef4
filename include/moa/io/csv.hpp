// Internal to moa's I/O: the line reader under every log-format CSV reader
// (docs/formats/log.md), so that all of them apply the same rules and word
// their errors the same way ("FILE:LINE: what is wrong").
//
// Rules it enforces: a header row first (comment lines before it are fine),
// '#' lines are comments anywhere, a trailing '\r' (CRLF files) is dropped,
// spaces and tabs around a field are dropped, every record has as many
// fields as the header, and blank lines are allowed only at the end of the
// file (a blank line followed by more content is reported at its own line).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace moa::io {

/// `text` with control characters written as \xNN, so that an error message
/// quoting input stays on one line.
std::string printable(std::string_view text);

/// The finite number `text` spells (std::from_chars general format, a
/// leading '+' allowed), or why it is not one: "'x' is not a number",
/// "'x' is out of range", "'x' is not a finite number" (nan, inf and YAML's
/// .nan, .inf spellings). The one number parser of moa's readers: CSV
/// fields, the robot config and the simulator's scenarios.
std::variant<double, std::string> parse_number(std::string_view text);

/// Room for any text of the two writers below (at most 24 chars) and the
/// scratch past its end that they may overwrite: give them this much.
inline constexpr std::size_t kMaxNumberText = 40;

/// Writes at `out` the shortest text that reads back as exactly `value`,
/// laid out as fmt's "{}" lays it out (fixed notation for decimal exponents
/// -4..15, else d.ddde+XX), and returns the end. The digits are
/// Dragonbox's (what fmt writes), several times faster than fmt's general
/// path. Needs kMaxNumberText chars of room at `out`.
char* write_shortest(char* out, double value);
/// Writes `value` as fmt's "{:.6g}" (printf's %.6g): six significant digits,
/// trailing zeros dropped. Needs kMaxNumberText chars of room at `out`.
char* write_6g(char* out, double value);

class CsvReader {
 public:
  /// Opens `file` and reads its header row; throws io::Error ("FILE: cannot
  /// open", "FILE:LINE: duplicate column 'x'", an empty file...).
  explicit CsvReader(const std::filesystem::path& file);

  /// The file as named in errors.
  const std::string& file() const { return file_; }
  /// 1-based line of the current record (the header's before the first next()).
  std::size_t line() const { return line_; }

  /// Index of the column called `name`, nullopt if the header has none.
  std::optional<std::size_t> column(std::string_view name) const;
  /// Index of a column the file must have; throws "FILE:LINE: missing column 'name'".
  std::size_t required_column(std::string_view name) const;

  /// Advances to the next record; false at the end of the file.
  bool next();

  /// Fields of the current record, by column index.
  std::string_view field(std::size_t column) const { return fields_[column]; }
  bool is_empty(std::size_t column) const { return fields_[column].empty(); }
  /// A finite floating point number.
  double number(std::size_t column) const;
  /// An integer within [min, max] (decimal digits, optional sign, nothing else).
  std::int64_t integer(std::size_t column, std::int64_t min, std::int64_t max) const;
  /// A finite number no earlier than the previous record's time.
  double time(std::size_t column);

  /// Throws io::Error "FILE:LINE: what" for the current line.
  [[noreturn]] void fail(std::string_view what) const;
  /// Throws io::Error "FILE:LINE: column 'name': what" for the current line.
  [[noreturn]] void fail_field(std::size_t column, std::string_view what) const;

 private:
  bool read_record();
  bool next_line(std::string_view& line);
  void refill();
  [[noreturn]] void fail_at(std::size_t line, std::string_view what) const;

  struct Close {
    void operator()(std::FILE* f) const { std::fclose(f); }
  };

  std::string file_;
  std::unique_ptr<std::FILE, Close> in_;
  // Bytes read from the file; [begin_, end_) not yet split into lines. The
  // current line, and so fields_, point into it until the next read_record().
  std::vector<char> block_;
  std::size_t begin_ = 0;
  std::size_t end_ = 0;
  bool eof_ = false;
  std::vector<std::string> header_;
  std::size_t header_line_ = 0;
  std::vector<std::string_view> fields_;
  std::size_t line_ = 0;
  std::size_t blank_line_ = 0;  // first blank line not yet followed by content, 0 if none
  std::optional<double> last_time_;
};

}  // namespace moa::io
