// Internal to moa's I/O: the line reader under every log-format CSV reader
// (docs/formats/log.md), so that all of them apply the same rules and word
// their errors the same way ("FILE:LINE: what is wrong").
//
// Rules it enforces: a header row first (comment lines before it are fine),
// '#' lines are comments anywhere, a trailing '\r' (CRLF files) is dropped,
// spaces and tabs around a field are dropped, every record has as many
// fields as the header, and blank lines are allowed only at the end of the
// file (a blank line followed by more content is reported at its own line).
//
// Bounds (docs/reliability.md): a line holds at most kMaxLineBytes bytes and
// is refused as soon as that many have been read without a '\n'; a time is
// within [-kMaxTime, kMaxTime] and at most kMaxSpan after the file's first
// (core/synchronise.hpp); an error quotes at most kMaxExcerpt bytes of input.
#pragma once

#include <cmath>
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

#include "moa/core/synchronise.hpp"

namespace moa::io {

/// Bytes in one line of a CSV file, its '\n' excluded.
inline constexpr std::size_t kMaxLineBytes = std::size_t{1} << 16;
/// Bytes of input an error message quotes at most.
inline constexpr std::size_t kMaxExcerpt = 40;

/// `text` with control characters and bytes that are not well-formed UTF-8
/// written as \xNN, so that an error message quoting input stays on one
/// line and is valid UTF-8 (valid multi-byte characters are kept).
std::string printable(std::string_view text);
/// printable() of at most the first kMaxExcerpt bytes of `text`, followed by
/// "... (N bytes)" when it was cut: how a reader quotes input in an error.
std::string excerpt(std::string_view text);

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
/// write_shortest() for values that are mostly short decimals (times):
/// tries m * 10^-6 before Dragonbox. The same text.
char* write_shortest_time(char* out, double value);
/// Writes `value` as fmt's "{:.6g}" (printf's %.6g): six significant digits,
/// trailing zeros dropped. Needs kMaxNumberText chars of room at `out`.
char* write_6g(char* out, double value);

/// "[-]ddd[.ddd]" (at most 19 digits, no exponent, no '+') from p: stores
/// its value, the double std::from_chars gives, and returns the end of the
/// text read; nullptr when the text at p is not of that form (the readers'
/// fast paths, which leave everything else to CsvReader::number). m / 10^k
/// with m < 2^53 and k <= 19 is exact in both operands and the division
/// rounds correctly: the double std::from_chars gives (Clinger's fast path),
/// at a fraction of its cost.
/// The text scan_decimal() read: m * 10^-fraction, negated when negative.
struct ShortDecimal {
  std::uint64_t m = 0;
  int fraction = 0;
  bool negative = false;
  bool operator==(const ShortDecimal&) const = default;
  double value() const {
    static constexpr double kPow10[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,
                                        1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19};
    const double magnitude = static_cast<double>(m) / kPow10[fraction];
    return negative ? -magnitude : magnitude;
  }
};

inline const char* scan_decimal(const char* p, const char* end, ShortDecimal& out) {
  const bool negative = p != end && *p == '-';
  if (negative) ++p;
  std::uint64_t m = 0;
  const char* const first = p;
  while (p != end && static_cast<unsigned>(*p - '0') < 10)
    m = 10 * m + static_cast<unsigned>(*p++ - '0');
  int digits = static_cast<int>(p - first);
  int fraction = 0;
  if (p != end && *p == '.') {
    const char* const point = ++p;
    while (p != end && static_cast<unsigned>(*p - '0') < 10)
      m = 10 * m + static_cast<unsigned>(*p++ - '0');
    fraction = static_cast<int>(p - point);
    digits += fraction;
  }
  if (digits == 0 || digits > 19 || m > (std::uint64_t{1} << 53)) return nullptr;
  out = {m, fraction, negative};
  return p;
}

inline const char* scan_decimal(const char* p, const char* end, double& value) {
  ShortDecimal d;
  p = scan_decimal(p, end, d);
  if (p) value = d.value();
  return p;
}

/// "[-]ddd" (1 to 18 digits) from p: stores its value and returns the end
/// of the digits, or nullptr.
inline const char* scan_integer(const char* p, const char* end, std::int64_t& value) {
  const bool negative = p != end && *p == '-';
  if (negative) ++p;
  const char* const first = p;
  std::int64_t v = 0;
  while (p != end && static_cast<unsigned>(*p - '0') < 10) {
    if (p - first == 18) return nullptr;
    v = 10 * v + (*p++ - '0');
  }
  if (p == first) return nullptr;
  value = negative ? -v : v;
  return p;
}

class CsvReader {
 public:
  /// Opens `file` and reads its header row; throws io::Error ("FILE: cannot
  /// open", "FILE:LINE: duplicate column 'x'", an empty file...).
  explicit CsvReader(const std::filesystem::path& file);

  /// The file as named in errors.
  const std::string& file() const { return file_; }
  /// 1-based line of the current record (the header's before the first next()).
  std::size_t line() const { return line_; }

  /// Columns of the header.
  std::size_t columns() const { return header_.size(); }
  /// Index of the column called `name`, nullopt if the header has none.
  std::optional<std::size_t> column(std::string_view name) const;
  /// Index of a column the file must have; throws "FILE:LINE: missing column 'name'".
  std::size_t required_column(std::string_view name) const;

  /// Advances to the next record; false at the end of the file.
  bool next();
  /// next() in two steps, for a reader's fast path: advances to the next
  /// record (comment and blank lines skipped, a trailing '\r' dropped)
  /// without cutting it into fields; split_record() then does what next()
  /// does next: the fields, and the error if there are not as many as columns.
  bool next_record();
  void split_record();
  /// The current record's text (valid until the next record is read).
  std::string_view record() const { return record_; }
  /// Takes t as the current record's time, as time() does, when it is not
  /// earlier than the previous record's; false otherwise (nothing changes).
  bool accept_time(double t) {
    if (last_time_ && t < *last_time_) return false;
    if (!(std::abs(t) <= kMaxTime) || (first_time_ && t - *first_time_ > kMaxSpan)) return false;
    if (!first_time_) first_time_ = t;
    last_time_ = t;
    return true;
  }

  /// Fields of the current record, by column index.
  std::string_view field(std::size_t column) const { return fields_[column]; }
  bool is_empty(std::size_t column) const { return fields_[column].empty(); }
  /// A finite floating point number.
  double number(std::size_t column) const;
  /// A number within [-bound, bound] (core/plausible.hpp); beyond: "column
  /// 'vx': 1.7e308 m/s is beyond the plausible -100..100 m/s of WHAT (a
  /// corrupt value?)", `unit` naming the column's unit.
  double plausible(std::size_t column, double bound, std::string_view unit,
                   std::string_view what) const;
  /// An integer within [min, max] (decimal digits, optional sign, nothing else).
  std::int64_t integer(std::size_t column, std::int64_t min, std::int64_t max) const;
  /// A finite number no earlier than the previous record's time, within
  /// [-kMaxTime, kMaxTime] s and at most kMaxSpan s after the file's first.
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
  [[noreturn]] void fail_long_line() const;

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
  std::string_view record_;
  std::vector<std::string_view> fields_;
  std::size_t line_ = 0;
  std::size_t blank_line_ = 0;  // first blank line not yet followed by content, 0 if none
  std::optional<double> first_time_;
  std::optional<double> last_time_;
};

}  // namespace moa::io
