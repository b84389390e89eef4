#include "moa/io/csv.hpp"

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

#include "moa/io/error.hpp"

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

// "[-]ddd[.ddd]" with at most 19 digits and no exponent (a time, a
// count), else nullopt. m / 10^k with m < 2^53 and k <= 22 is exact in
// both operands, and the division rounds correctly: the double that
// std::from_chars gives (Clinger's fast path), at a fraction of its cost.
std::optional<double> short_decimal(std::string_view text) {
  static constexpr double kPow10[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                      1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
                                      1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
  const char* p = text.data();
  const char* const end = p + text.size();
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
  if (p != end || digits == 0 || digits > 19 || m > (std::uint64_t{1} << 53)) return std::nullopt;
  const double value = static_cast<double>(m) / kPow10[fraction];
  return negative ? -value : value;
}

// "[-]ddd" with at most 18 digits, else nullopt (std::from_chars's value).
std::optional<std::int64_t> short_integer(std::string_view text) {
  const char* p = text.data();
  const char* const end = p + text.size();
  const bool negative = p != end && *p == '-';
  if (negative) ++p;
  if (p == end || end - p > 18) return std::nullopt;
  std::int64_t value = 0;
  for (; p != end; ++p) {
    const auto digit = static_cast<unsigned>(*p - '0');
    if (digit >= 10) return std::nullopt;
    value = 10 * value + digit;
  }
  return negative ? -value : value;
}

// The first block; it doubles for a line that does not fit.
constexpr std::size_t kBlockSize = std::size_t{1} << 16;

// from_chars rejects a leading '+', which people and some tools write.
std::string_view without_plus(std::string_view text) {
  if (text.size() > 1 && text[0] == '+' && text[1] != '-' && text[1] != '+') text.remove_prefix(1);
  return text;
}

}  // namespace

std::string printable(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    const auto u = static_cast<unsigned char>(c);
    if (u < 0x20 || u == 0x7f) {
      out += fmt::format("\\x{:02x}", u);
    } else {
      out += c;
    }
  }
  return out;
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

void put8(char* out, std::uint32_t v) {
  if constexpr (std::endian::native == std::endian::little) {
    const std::uint64_t digits = digits8(v);
    std::memcpy(out, &digits, 8);
  } else {
    for (int i = 7; i >= 0; --i, v /= 10) out[i] = static_cast<char>('0' + v % 10);
  }
}

// The decimal digits of v (n of them, v < 10^n <= 10^24), right-aligned to
// end at buffer + 24, followed by 24 '0's. Returns the first digit.
const char* put_digits(char (&buffer)[48], std::uint64_t v, int n) {
  std::memset(buffer + 24, '0', 24);
  if (n <= 8) {
    put8(buffer + 16, static_cast<std::uint32_t>(v));
  } else if (n <= 16) {
    put8(buffer + 8, static_cast<std::uint32_t>(v / 100000000));
    put8(buffer + 16, static_cast<std::uint32_t>(v % 100000000));
  } else {
    const std::uint64_t high = v / 100000000;
    put8(buffer, static_cast<std::uint32_t>(high / 100000000));
    put8(buffer + 8, static_cast<std::uint32_t>(high % 100000000));
    put8(buffer + 16, static_cast<std::uint32_t>(v % 100000000));
  }
  return buffer + 24 - n;
}

// significand * 10^exponent (significand > 0, no trailing zeros, at most 17
// digits), as fmt's general format without a precision lays it out: fixed
// notation when the decimal exponent of the first digit is in [-4, upper),
// upper <= 16, else d.ddde+XX with at least two exponent digits. The digits
// are copied in fixed 16- and 24-byte blocks: bytes past the returned end,
// up to out + kMaxNumberText - 1, may be overwritten.
char* put_decimal(char* out, std::uint64_t significand, int exponent, int upper) {
  const int n = count_digits(significand);
  const int first = exponent + n - 1;  // decimal exponent of the first digit
  char buffer[48];
  const char* digits = put_digits(buffer, significand, n);
  if (first < -4 || first >= upper) {
    out[0] = digits[0];
    if (n > 1) {
      out[1] = '.';
      std::memcpy(out + 2, digits + 1, 16);
      out += n + 1;
    } else {
      out += 1;
    }
    *out++ = 'e';
    *out++ = first < 0 ? '-' : '+';
    const int e = first < 0 ? -first : first;
    if (e >= 100) *out++ = static_cast<char>('0' + e / 100);
    *out++ = static_cast<char>('0' + e / 10 % 10);
    *out++ = static_cast<char>('0' + e % 10);
    return out;
  }
  if (exponent >= 0) {  // 1234e5 -> 123400000: the zeros follow the digits
    std::memcpy(out, digits, 16);
    return out + n + exponent;
  }
  const int whole = exponent + n;  // digits before the point
  if (whole > 0) {                 // 1234e-2 -> 12.34
    std::memcpy(out, digits, 16);
    out[whole] = '.';
    std::memcpy(out + whole + 1, digits + whole, 16);
    return out + n + 1;
  }
  std::memcpy(out, "0.000", 5);  // 1234e-6 -> 0.001234
  std::memcpy(out + 2 - whole, digits, 24);
  return out + 2 - whole + n;
}

// value > 0 as m * 10^-6 when that reads back as value: the shortest text
// then, since below 10^9 the doubles that read back as value span less than
// 10^-6 and hold no other multiple of it (times, rates: most of them are
// such). The quotient m / 10^6 of exact operands (m < 2^53) is correctly
// rounded: the double a correct parser makes of m * 10^-6.
bool short_decimal_digits(double value, std::uint64_t& significand, int& exponent) {
  if (!(value < 1e9)) return false;
  const auto m = static_cast<std::uint64_t>(value * 1e6 + 0.5);
  if (m == 0 || static_cast<double>(m) / 1e6 != value) return false;
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
  std::uint64_t significand = 0;
  int exponent = 0;
  if (short_decimal_digits(value, significand, exponent)) {
    return put_decimal(out, significand, exponent, 16);
  }
  const auto decimal = fmt::detail::dragonbox::to_decimal(value);
  return put_decimal(out, decimal.significand, decimal.exponent, 16);
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
  header_.reserve(fields_.size());
  for (std::size_t i = 0; i < fields_.size(); ++i) {
    if (fields_[i].empty()) fail(fmt::format("column {} of the header has no name", i + 1));
    if (column(fields_[i])) fail(fmt::format("duplicate column '{}'", fields_[i]));
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
  if (end_ == block_.size()) block_.resize(2 * block_.size());
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
      line = {start, length};
      begin_ += length + 1;
      return true;
    }
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
  std::string_view line;
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
    split(line, fields_);
    return true;
  }
  return false;
}

bool CsvReader::next() {
  if (!read_record()) return false;
  if (fields_.size() != header_.size()) {
    fail(fmt::format("expected {} fields, found {}", header_.size(), fields_.size()));
  }
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
    return fmt::format("'{}' is not a finite number", text);
  }
  if (ec == std::errc::result_out_of_range && whole) {
    return fmt::format("'{}' is out of range", text);
  }
  if (ec != std::errc{} || !whole) return fmt::format("'{}' is not a number", text);
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
    fail_field(column, fmt::format("{} is outside {}..{}", text, min, max));
  }
  if (ec != std::errc{} || end != digits.data() + digits.size()) {
    fail_field(column, fmt::format("'{}' is not an integer", text));
  }
  if (value < min || value > max)
    fail_field(column, fmt::format("{} is outside {}..{}", text, min, max));
  return value;
}

double CsvReader::time(std::size_t column) {
  const double t = number(column);
  if (last_time_ && t < *last_time_) {
    fail(fmt::format("time goes backwards ({} after {})", t, *last_time_));
  }
  last_time_ = t;
  return t;
}

void CsvReader::fail(std::string_view what) const { fail_at(line_, what); }

void CsvReader::fail_at(std::size_t line, std::string_view what) const {
  throw Error(printable(fmt::format("{}:{}: {}", file_, line, what)));
}

void CsvReader::fail_field(std::size_t column, std::string_view what) const {
  fail(fmt::format("column '{}': {}", header_[column], what));
}

}  // namespace moa::io
