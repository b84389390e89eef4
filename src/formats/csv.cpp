#include "moa/formats/csv.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <string>
#include <system_error>

#include "moa/formats/error.hpp"

namespace moa::io {
namespace {

bool is_blank(char c) { return c == ' ' || c == '\t'; }

std::string_view trim(std::string_view s) {
  const char* first = s.data();
  const char* last = first + s.size();
  while (first != last && is_blank(*first)) ++first;
  while (last != first && is_blank(last[-1])) --last;
  return {first, static_cast<std::size_t>(last - first)};
}

// Fields are short: a byte loop beats a memchr call per field.
void split(std::string_view line, std::vector<std::string_view>& fields) {
  fields.clear();
  const char* p = line.data();
  const char* const end = p + line.size();
  while (true) {
    const char* q = p;
    while (q != end && *q != ',') ++q;
    fields.push_back(trim({p, static_cast<std::size_t>(q - p)}));
    if (q == end) return;
    p = q + 1;
  }
}

std::optional<double> short_decimal(std::string_view text) {
  double value = 0.0;
  const char* const end = text.data() + text.size();
  if (scan_decimal(text.data(), end, value) != end) return std::nullopt;
  return value;
}

std::optional<std::int64_t> short_integer(std::string_view text) {
  std::int64_t value = 0;
  const char* const end = text.data() + text.size();
  if (scan_integer(text.data(), end, value) != end) return std::nullopt;
  return value;
}

// The first block; it doubles for a line that does not fit.
constexpr std::size_t kBlockSize = std::size_t{1} << 16;

// from_chars rejects a leading '+', which people and some tools write.
std::string_view without_plus(std::string_view text) {
  if (text.size() > 1 && text[0] == '+' && text[1] != '-' && text[1] != '+') text.remove_prefix(1);
  return text;
}

}  // namespace

namespace {
// Bytes in the well-formed UTF-8 sequence at text[i] (1 to 4), 0 if none
// starts there (a stray continuation byte, an overlong form, a surrogate,
// beyond U+10FFFF, or cut short).
std::size_t utf8_sequence(std::string_view text, std::size_t i) {
  const auto at = [&](std::size_t k) { return static_cast<unsigned char>(text[k]); };
  const unsigned char b = at(i);
  std::size_t n = 0;
  unsigned char lo = 0x80, hi = 0xbf;  // the second byte's range
  if (b >= 0xc2 && b <= 0xdf) {
    n = 2;
  } else if (b >= 0xe0 && b <= 0xef) {
    n = 3;
    if (b == 0xe0) lo = 0xa0;
    if (b == 0xed) hi = 0x9f;
  } else if (b >= 0xf0 && b <= 0xf4) {
    n = 4;
    if (b == 0xf0) lo = 0x90;
    if (b == 0xf4) hi = 0x8f;
  } else {
    return 0;
  }
  if (i + n > text.size()) return 0;
  if (at(i + 1) < lo || at(i + 1) > hi) return 0;
  for (std::size_t k = 2; k < n; ++k) {
    if (at(i + k) < 0x80 || at(i + k) > 0xbf) return 0;
  }
  return n;
}
}  // namespace

std::string printable(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size();) {
    const auto u = static_cast<unsigned char>(text[i]);
    if (u < 0x80) {
      if (u < 0x20 || u == 0x7f) {
        out += fmt::format("\\x{:02x}", u);
      } else {
        out += text[i];
      }
      ++i;
      continue;
    }
    // Valid UTF-8 is kept (a name in any script); any other byte is
    // written \xNN, so that the message is valid UTF-8 on any terminal.
    if (const std::size_t n = utf8_sequence(text, i); n != 0) {
      out.append(text.substr(i, n));
      i += n;
    } else {
      out += fmt::format("\\x{:02x}", u);
      ++i;
    }
  }
  return out;
}

std::string excerpt(std::string_view text) {
  if (text.size() <= kMaxExcerpt) return printable(text);
  return fmt::format("{}... ({} bytes)", printable(text.substr(0, kMaxExcerpt)), text.size());
}

namespace {

constexpr std::array<std::uint64_t, 20> kPow10 = [] {
  std::array<std::uint64_t, 20> p{};
  p[0] = 1;
  for (std::size_t i = 1; i < p.size(); ++i) p[i] = 10 * p[i - 1];
  return p;
}();

// floor(log10(v)) + 1 for v > 0: log10(2) ~ 1233 / 4096 from the bit length.
int count_digits(std::uint64_t v) {
  const int bits = 64 - std::countl_zero(v | 1);
  const int guess = bits * 1233 >> 12;  // floor(log10(v)) or one more
  return guess + (v >= kPow10[static_cast<std::size_t>(guess)] ? 1 : 0);
}

// The eight decimal digits of v < 10^8, leading zeros included, as the
// eight bytes of a little-endian word: v split into two 4-digit halves, each
// into two 2-digit quarters, each into two digits, every step in all lanes
// of the word at once (x / 100 as x * 10486 >> 20 for x < 10^4, x / 10 as
// x * 103 >> 10 for x < 100; checked against printf for every v < 10^8).
std::uint64_t digits8(std::uint32_t v) {
  const std::uint64_t high = v / 10000, low = v % 10000;
  std::uint64_t x = high | low << 32;
  const std::uint64_t h100 = (x * 10486 >> 20) & 0x0000007F0000007Fu;
  x = h100 | (x - h100 * 100) << 16;
  const std::uint64_t h10 = (x * 103 >> 10) & 0x000F000F000F000Fu;
  x = h10 | (x - h10 * 10) << 8;
  return x | 0x3030303030303030u;
}

// The eight bytes of x at out, the low byte first.
void store8(char* out, std::uint64_t x) {
  if constexpr (std::endian::native == std::endian::little) {
    std::memcpy(out, &x, 8);
  } else {
    for (int i = 0; i < 8; ++i) out[i] = static_cast<char>(x >> (8 * i));
  }
}

// Bytes [offset, offset + 8) of the string whose bytes are those of the
// words w, the low byte of each first: two words shifted into one, so that
// the digits move from registers to their place without being read back
// from memory (a load spanning two recent stores stalls the CPU).
std::uint64_t window(const std::uint64_t* w, int offset) {
  const auto q = static_cast<std::size_t>(offset >> 3);
  const int r = (offset & 7) * 8;
  return w[q] >> r | (w[q + 1] << 1) << (63 - r);
}

// The last k (1 to 17) digits of the 17-digit string S = d0 D1 D2 (d0 one
// digit char, D1 and D2 eight digit chars each as from digits8()), at out,
// from registers: the bytes of a word shifted right by whole bytes drop its
// first digits. Returns out + k; up to 8 bytes past it may be overwritten.
char* put_last_digits(char* out, int k, char d0, std::uint64_t d1, std::uint64_t d2) {
  if (k <= 8) {
    store8(out, d2 >> (8 * (8 - k)));
  } else if (k <= 16) {
    store8(out, d1 >> (8 * (16 - k)));
    store8(out + k - 8, d2);
  } else {
    out[0] = d0;
    store8(out + 1, d1);
    store8(out + 9, d2);
  }
  return out + k;
}

// put_decimal() for the layouts of most doubles, fixed notation with
// digits after the point: d.ddd with at least nine of them after it, or
// 0.0ddd. Nothing is shifted through memory: S, the significand as 17 digits
// with leading zeros, is cut at the point (the last -exponent digits are
// the fraction). Returns nullptr, having written nothing, for other layouts.
char* put_fraction(char* out, std::uint64_t significand, int exponent, int n, int whole) {
  const int fraction = -exponent;  // digits after the point
  if (whole > 0 && fraction < 9) return nullptr;
  const std::uint64_t high = significand / 100000000;
  const std::uint64_t d2 = digits8(static_cast<std::uint32_t>(significand % 100000000));
  const std::uint64_t d1 = digits8(static_cast<std::uint32_t>(high % 100000000));
  const char d0 = static_cast<char>('0' + high / 100000000);
  // 1234e-6 -> 0.001234: "0.", -whole zeros, the n digits.
  if (whole <= 0) {
    store8(out, 0x3030303030302e30u);  // "0.000000"
    return put_last_digits(out + 2 - whole, n, d0, d1, d2);
  }
  // The whole digits are S[17 - n, 17 - fraction), within S's first eight
  // bytes (fraction >= 9), so n >= 10: a shift by 17 - n <= 7 bytes.
  const std::uint64_t first8 = static_cast<unsigned char>(d0) | d1 << 8;
  store8(out, first8 >> (8 * (17 - n)));
  out[whole] = '.';
  return put_last_digits(out + whole + 1, fraction, d0, d1, d2);
}

// put_decimal() (below) of any layout; n is the number of digits.
char* put_any_decimal(char* out, std::uint64_t significand, int exponent, int upper, int n) {
  constexpr std::uint64_t kZeros = 0x3030303030303030u;  // "00000000"
  const int first = exponent + n - 1;                    // decimal exponent of the first digit
  // The digits right-aligned in bytes [0, 24), '0's after them.
  std::uint64_t w[6] = {kZeros, kZeros, kZeros, kZeros, kZeros, kZeros};
  w[2] = digits8(static_cast<std::uint32_t>(significand % 100000000));
  if (n > 8) {
    const std::uint64_t high = significand / 100000000;
    w[1] = digits8(static_cast<std::uint32_t>(high % 100000000));
    if (n > 16) w[0] += (high / 100000000) << 56;  // "0000000d": one digit
  }
  const int s = 24 - n;  // the first digit
  if (first < -4 || first >= upper) {
    out[0] = static_cast<char>(window(w, s));
    out[1] = '.';
    store8(out + 2, window(w, s + 1));
    store8(out + 10, window(w, s + 9));
    out += n > 1 ? n + 1 : 1;
    *out++ = 'e';
    *out++ = first < 0 ? '-' : '+';
    const int e = first < 0 ? -first : first;
    if (e >= 100) *out++ = static_cast<char>('0' + e / 100);
    *out++ = static_cast<char>('0' + e / 10 % 10);
    *out++ = static_cast<char>('0' + e % 10);
    return out;
  }
  store8(out, window(w, s));
  store8(out + 8, window(w, s + 8));
  if (exponent >= 0) {  // 1234e5 -> 123400000: the '0's follow the digits
    return out + n + exponent;
  }
  const int whole = exponent + n;  // digits before the point
  // Doubles mostly have 16 or 17 digits: w[1] and w[2] hold all but the
  // first of 17, which is the last byte of w[0], and no shifting is needed
  // for d.ddd or 0.0ddd.
  if (n == 17 && whole == 1) {
    out[1] = '.';
    store8(out + 2, w[1]);
    store8(out + 10, w[2]);
    out[0] = static_cast<char>(w[0] >> 56);
    return out + 18;
  }
  if (whole > 0) {  // 1234e-2 -> 12.34
    out[whole] = '.';
    store8(out + whole + 1, window(w, s + whole));
    store8(out + whole + 9, window(w, s + whole + 8));
    return out + n + 1;
  }
  store8(out, 0x3030303030302e30u);  // "0.000000": 1234e-6 -> 0.001234
  char* digits = out + 2 - whole;
  if (n >= 16) {
    char* const end = digits + n;
    if (n == 17) *digits++ = static_cast<char>(w[0] >> 56);
    store8(digits, w[1]);
    store8(digits + 8, w[2]);
    return end;
  }
  store8(digits, window(w, s));
  store8(digits + 8, window(w, s + 8));
  return digits + n;
}

// significand * 10^exponent (significand > 0, no trailing zeros, at most 17
// digits), as fmt's general format without a precision lays it out: fixed
// notation when the decimal exponent of the first digit is in [-4, upper),
// upper <= 16, else d.ddde+XX with at least two exponent digits. The text
// is stored eight bytes at a time: bytes past the returned end, up to
// out + kMaxNumberText - 1, may be overwritten. The common layouts first,
// in a function small enough to be inlined into the writers.
inline char* put_decimal(char* out, std::uint64_t significand, int exponent, int upper) {
  const int n = count_digits(significand);
  const int first = exponent + n - 1;  // decimal exponent of the first digit
  if (exponent < 0 && first >= -4 && first < upper) {
    if (char* end = put_fraction(out, significand, exponent, n, first + 1)) return end;
  }
  return put_any_decimal(out, significand, exponent, upper, n);
}

// value > 0 as m * 10^-6 when that reads back as value: the shortest text
// then, since below 10^9 the doubles that read back as value span less than
// 10^-6 and hold no other multiple of it (times, rates: most of them are
// such). The quotient m / 10^6 of exact operands (m < 2^53) is correctly
// rounded: the double a correct parser makes of m * 10^-6.
bool short_decimal_digits(double value, std::uint64_t& significand, int& exponent) {
  if (!(value < 1e9)) return false;
  const double scaled = value * 1e6;
  const auto m = static_cast<std::uint64_t>(scaled + 0.5);
  // value = m / 10^6 (1 + d), |d| <= 2^-53, puts scaled within m 2^-51 of
  // m: anything farther cannot pass the division's test (a slow one).
  const double near = static_cast<double>(m);
  if (m == 0 || std::abs(scaled - near) > near * 0x1p-50 || near / 1e6 != value) return false;
  significand = m;
  exponent = -6;
  while (significand % 10 == 0) {
    significand /= 10;
    ++exponent;
  }
  return true;
}

}  // namespace

// The digits are Dragonbox's (Jeon 2020: the shortest decimal in the
// rounding interval of `value`, the closest to it when several are), the
// very digits fmt's "{}" writes: it calls the same function.
char* write_shortest(char* out, double value) {
  if (!std::isfinite(value)) return fmt::format_to(out, "{}", value);
  if (std::signbit(value)) {
    *out++ = '-';
    value = -value;
  }
  if (value == 0.0) {
    *out++ = '0';
    return out;
  }
  const auto decimal = fmt::detail::dragonbox::to_decimal(value);
  return put_decimal(out, decimal.significand, decimal.exponent, 16);
}

char* write_shortest_time(char* out, double value) {
  std::uint64_t significand = 0;
  int exponent = 0;
  if (value > 0.0 && short_decimal_digits(value, significand, exponent)) {
    return put_decimal(out, significand, exponent, 16);
  }
  return write_shortest(out, value);
}

// Six significant digits from the shortest ones D (n digits). Rounding D
// instead of the exact value x gives the same six digits unless a rounding
// boundary M (six digits and a 5) lies between x and D or on D. Between is
// impossible: M would be in x's rounding interval with at most as many
// digits as D and, for n = 7, closer to x, so Dragonbox would have returned
// M. On D (n = 7, last digit 5) the tie is decided by x itself: fmt does it.
// The argument needs an interval far narrower than the six-digit spacing:
// true of normal doubles (2^-53 relative), not of subnormal ones.
char* write_6g(char* out, double value) {
  if (!std::isnormal(value)) {
    if (value == 0.0) {
      if (std::signbit(value)) *out++ = '-';
      *out++ = '0';
      return out;
    }
    return fmt::format_to(out, "{:.6g}", value);
  }
  const bool negative = std::signbit(value);
  const double magnitude = negative ? -value : value;
  const auto decimal = fmt::detail::dragonbox::to_decimal(magnitude);
  std::uint64_t significand = decimal.significand;
  int exponent = decimal.exponent;
  const int n = count_digits(significand);
  if (n > 6) {
    const std::uint64_t unit = kPow10[static_cast<std::size_t>(n - 6)];
    const std::uint64_t rest = significand % unit;
    if (rest == unit / 2) return fmt::format_to(out, "{:.6g}", value);
    significand = significand / unit + (rest > unit / 2 ? 1 : 0);
    exponent += n - 6;
  }
  while (significand % 10 == 0) {  // 999999|7 -> 1000000 -> 1; %g drops trailing zeros
    significand /= 10;
    ++exponent;
  }
  if (negative) *out++ = '-';
  return put_decimal(out, significand, exponent, 6);
}

CsvReader::CsvReader(const std::filesystem::path& file) : file_(file.string()) {
  std::error_code ec;
  if (std::filesystem::is_directory(file, ec)) {
    throw IoError(fmt::format("{}: cannot open (is a directory)", file_));
  }
  in_.reset(std::fopen(file.c_str(), "rb"));
  if (!in_) throw IoError(fmt::format("{}: cannot open", file_));
  block_.resize(kBlockSize);
  if (!read_record()) fail_at(line_ + 1, "no header row (the file is empty)");
  header_line_ = line_;
  // A first line that starts with a number is data: the header is missing
  // (else its repeated values read as duplicate column names).
  if (!fields_.empty() && std::holds_alternative<double>(parse_number(fields_[0]))) {
    fail(
        fmt::format("no header row: the first line is data ('{}'...); the first line names the "
                    "columns",
                    excerpt(fields_[0])));
  }
  header_.reserve(fields_.size());
  for (std::size_t i = 0; i < fields_.size(); ++i) {
    if (fields_[i].empty()) fail(fmt::format("column {} of the header has no name", i + 1));
    if (column(fields_[i])) fail(fmt::format("duplicate column '{}'", excerpt(fields_[i])));
    header_.emplace_back(fields_[i]);
  }
}

std::optional<std::size_t> CsvReader::column(std::string_view name) const {
  const auto it = std::find(header_.begin(), header_.end(), name);
  if (it == header_.end()) return std::nullopt;
  return static_cast<std::size_t>(it - header_.begin());
}

std::size_t CsvReader::required_column(std::string_view name) const {
  if (auto c = column(name)) return *c;
  fail_at(header_line_, fmt::format("missing column '{}'", name));
}

void CsvReader::refill() {
  // Keep the partial line, at the front of the block.
  if (begin_ > 0) {
    std::memmove(block_.data(), block_.data() + begin_, end_ - begin_);
    end_ -= begin_;
    begin_ = 0;
  }
  // A line may fill the block only while it is not yet known to be too long.
  if (end_ == block_.size()) block_.resize(std::max(2 * block_.size(), kMaxLineBytes + 2));
  const std::size_t n = std::fread(block_.data() + end_, 1, block_.size() - end_, in_.get());
  end_ += n;
  if (n == 0) {
    if (std::ferror(in_.get())) fail_at(line_ + 1, "read error");
    eof_ = true;
  }
}

// As std::getline: lines end at '\n', the last one may lack it.
bool CsvReader::next_line(std::string_view& line) {
  while (true) {
    const char* start = block_.data() + begin_;
    const std::size_t size = end_ - begin_;
    if (const void* nl = std::memchr(start, '\n', size)) {
      const auto length = static_cast<std::size_t>(static_cast<const char*>(nl) - start);
      if (length > kMaxLineBytes) fail_long_line();
      line = {start, length};
      begin_ += length + 1;
      return true;
    }
    if (size > kMaxLineBytes) fail_long_line();
    if (eof_) {
      if (size == 0) return false;
      line = {start, size};
      begin_ = end_;
      return true;
    }
    refill();
  }
}

bool CsvReader::read_record() {
  if (!next_record()) return false;
  split(record_, fields_);
  return true;
}

bool CsvReader::next_record() {
  std::string_view& line = record_;
  while (next_line(line)) {
    ++line_;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    // A UTF-8 byte order mark (spreadsheets on Windows write one) is not data.
    if (line_ == 1 && line.starts_with("\xEF\xBB\xBF")) line.remove_prefix(3);
    if (line.empty() || (is_blank(line.front()) && trim(line).empty())) {
      if (blank_line_ == 0) blank_line_ = line_;
      continue;
    }
    if (blank_line_ != 0) fail_at(blank_line_, "blank line (only allowed at the end of the file)");
    if (line.front() == '#') continue;
    return true;
  }
  return false;
}

void CsvReader::split_record() {
  split(record_, fields_);
  if (fields_.size() != header_.size()) {
    fail(fmt::format("expected {} fields, found {}", header_.size(), fields_.size()));
  }
}

bool CsvReader::next() {
  if (!next_record()) return false;
  split_record();
  return true;
}

std::variant<double, std::string> parse_number(std::string_view text) {
  const std::string_view digits = without_plus(text);
  double value = 0.0;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value,
                                         std::chars_format::general);
  const bool whole = end == digits.data() + digits.size();
  if (ec == std::errc{} && whole && std::isfinite(value)) return value;
  // YAML spells them .nan, .inf, -.Inf, which from_chars does not take.
  std::string word(text);
  std::transform(word.begin(), word.end(), word.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  std::string_view bare = word;
  if (!bare.empty() && (bare[0] == '-' || bare[0] == '+')) bare.remove_prefix(1);
  if (!bare.empty() && bare[0] == '.') bare.remove_prefix(1);
  const bool spelled_non_finite = bare == "nan" || bare == "inf" || bare == "infinity";
  if ((ec == std::errc{} && whole && !std::isfinite(value)) ||
      (ec != std::errc{} && spelled_non_finite)) {
    return fmt::format("'{}' is not a finite number", excerpt(text));
  }
  if (ec == std::errc::result_out_of_range && whole) {
    return fmt::format("'{}' is out of range", excerpt(text));
  }
  if (ec != std::errc{} || !whole) return fmt::format("'{}' is not a number", excerpt(text));
  return value;
}

double CsvReader::number(std::size_t column) const {
  const std::string_view text = fields_[column];
  if (text.empty()) fail_field(column, "empty field");
  if (const auto value = short_decimal(text)) return *value;
  // Anything else as parse_number reads it, without building its variant
  // when the text is a number.
  double value = 0.0;
  const char* const last = text.data() + text.size();
  const auto [end, ec] = std::from_chars(text.data(), last, value, std::chars_format::general);
  if (ec == std::errc{} && end == last && std::isfinite(value)) return value;
  const auto parsed = parse_number(text);
  if (const auto* error = std::get_if<std::string>(&parsed)) fail_field(column, *error);
  return std::get<double>(parsed);
}

double CsvReader::plausible(std::size_t column, double bound, std::string_view unit,
                            std::string_view what) const {
  const double value = number(column);
  if (!(std::abs(value) <= bound)) {
    fail_field(column,
               fmt::format("{} {} is beyond the plausible {}..{} {} of {} (a corrupt value?)",
                           excerpt(fields_[column]), unit, -bound, bound, unit, what));
  }
  return value;
}

std::int64_t CsvReader::integer(std::size_t column, std::int64_t min, std::int64_t max) const {
  const std::string_view text = fields_[column];
  if (text.empty()) fail_field(column, "empty field");
  if (const auto value = short_integer(text); value && *value >= min && *value <= max) {
    return *value;
  }
  const std::string_view digits = without_plus(text);
  std::int64_t value = 0;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (ec == std::errc::result_out_of_range && end == digits.data() + digits.size()) {
    fail_field(column, fmt::format("{} is outside {}..{}", excerpt(text), min, max));
  }
  if (ec != std::errc{} || end != digits.data() + digits.size()) {
    fail_field(column, fmt::format("'{}' is not an integer", excerpt(text)));
  }
  if (value < min || value > max)
    fail_field(column, fmt::format("{} is outside {}..{}", excerpt(text), min, max));
  return value;
}

double CsvReader::time(std::size_t column) {
  const double t = number(column);
  if (!(std::abs(t) <= kMaxTime)) {
    static_assert(kMaxTime == 4e9, "the message below says 4e9");
    fail_field(column, fmt::format("{} s is outside -4e9..4e9 s (beyond, a double no longer "
                                   "resolves the epoch step exactly)",
                                   excerpt(fields_[column])));
  }
  if (first_time_ && t - *first_time_ > kMaxSpan) {
    fail_field(column,
               fmt::format("{} s is {:g} s after the file's first time ({} s): more than "
                           "{:g} s (one day) in one log",
                           excerpt(fields_[column]), t - *first_time_, *first_time_, kMaxSpan));
  }
  if (last_time_ && t < *last_time_) {
    fail(fmt::format("time goes backwards ({} after {})", t, *last_time_));
  }
  if (!first_time_) first_time_ = t;
  last_time_ = t;
  return t;
}

void CsvReader::fail(std::string_view what) const { fail_at(line_, what); }

void CsvReader::fail_long_line() const {
  fail_at(line_ + 1,
          fmt::format("line longer than {} bytes: not a CSV file of moa's", kMaxLineBytes));
}

void CsvReader::fail_at(std::size_t line, std::string_view what) const {
  throw Error(printable(fmt::format("{}:{}: {}", file_, line, what)));
}

void CsvReader::fail_field(std::size_t column, std::string_view what) const {
  fail(fmt::format("column '{}': {}", excerpt(header_[column]), what));
}

}  // namespace moa::io
