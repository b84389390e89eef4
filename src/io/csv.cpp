#include "moa/io/csv.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <string>
#include <system_error>

#include "moa/io/error.hpp"

namespace moa::io {
namespace {

std::string_view trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t");
  if (first == std::string_view::npos) return {};
  const auto last = s.find_last_not_of(" \t");
  return s.substr(first, last - first + 1);
}

void split(std::string_view line, std::vector<std::string_view>& fields) {
  fields.clear();
  while (true) {
    const auto comma = line.find(',');
    fields.push_back(trim(line.substr(0, comma)));
    if (comma == std::string_view::npos) return;
    line.remove_prefix(comma + 1);
  }
}

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

CsvReader::CsvReader(const std::filesystem::path& file) : file_(file.string()) {
  std::error_code ec;
  if (std::filesystem::is_directory(file, ec)) {
    throw IoError(fmt::format("{}: cannot open (is a directory)", file_));
  }
  in_.open(file, std::ios::binary);
  if (!in_) throw IoError(fmt::format("{}: cannot open", file_));
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

bool CsvReader::read_record() {
  while (std::getline(in_, buffer_)) {
    ++line_;
    if (!buffer_.empty() && buffer_.back() == '\r') buffer_.pop_back();
    // A UTF-8 byte order mark (spreadsheets on Windows write one) is not data.
    if (line_ == 1 && buffer_.starts_with("\xEF\xBB\xBF")) buffer_.erase(0, 3);
    if (trim(buffer_).empty()) {
      if (blank_line_ == 0) blank_line_ = line_;
      continue;
    }
    if (blank_line_ != 0) fail_at(blank_line_, "blank line (only allowed at the end of the file)");
    if (buffer_.front() == '#') continue;
    split(buffer_, fields_);
    return true;
  }
  if (in_.bad()) fail_at(line_ + 1, "read error");
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
  const auto parsed = parse_number(text);
  if (const auto* error = std::get_if<std::string>(&parsed)) fail_field(column, *error);
  return std::get<double>(parsed);
}

std::int64_t CsvReader::integer(std::size_t column, std::int64_t min, std::int64_t max) const {
  const std::string_view text = fields_[column];
  if (text.empty()) fail_field(column, "empty field");
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
