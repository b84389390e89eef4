#include "moa/sources/evemu.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <fstream>
#include <limits>
#include <string_view>
#include <variant>

#include "moa/formats/csv.hpp"
#include "moa/formats/error.hpp"

namespace moa::io {
namespace {

constexpr std::uint16_t kEvSyn = 0x00;
constexpr std::uint16_t kEvRel = 0x02;
constexpr std::uint16_t kSynReport = 0x00;
constexpr std::uint16_t kSynDropped = 0x03;
constexpr std::uint16_t kRelX = 0x00;
constexpr std::uint16_t kRelY = 0x01;

// Seconds beyond this would overflow the nanosecond count in 64 bits.
constexpr std::int64_t kMaxSeconds = 9'000'000'000;

struct Event {
  std::int64_t time_ns = 0;
  std::uint16_t type = 0;
  std::uint16_t code = 0;
  std::int32_t value = 0;
};

struct Frame {
  std::int64_t time_ns = 0;
  std::int64_t dx = 0;
  std::int64_t dy = 0;
};

bool is_blank(char c) { return c == ' ' || c == '\t'; }

std::string_view trim(std::string_view text) {
  while (!text.empty() && is_blank(text.front())) text.remove_prefix(1);
  while (!text.empty() && is_blank(text.back())) text.remove_suffix(1);
  return text;
}

// Quoted input in an error stays short and on one line.
std::string quote(std::string_view text) { return excerpt(text); }

// Whitespace separated fields up to a '#' comment.
std::vector<std::string_view> fields_of(std::string_view text) {
  std::vector<std::string_view> fields;
  std::size_t at = 0;
  while (at < text.size()) {
    while (at < text.size() && is_blank(text[at])) ++at;
    if (at >= text.size() || text[at] == '#') break;
    const std::size_t start = at;
    while (at < text.size() && !is_blank(text[at])) ++at;
    fields.push_back(text.substr(start, at - start));
  }
  return fields;
}

bool is_digit(char c) { return c >= '0' && c <= '9'; }

std::optional<std::int64_t> parse_time_ns(std::string_view text) {
  const std::size_t dot = text.find('.');
  if (dot == std::string_view::npos || dot == 0 || dot + 1 == text.size()) return std::nullopt;
  const std::string_view seconds = text.substr(0, dot);
  const std::string_view fraction = text.substr(dot + 1);
  if (seconds.size() > 10 || fraction.size() > 9) return std::nullopt;
  std::int64_t s = 0;
  for (const char c : seconds) {
    if (!is_digit(c)) return std::nullopt;
    s = s * 10 + (c - '0');
  }
  if (s > kMaxSeconds) return std::nullopt;
  std::int64_t ns = 0;
  std::int64_t scale = 100'000'000;
  for (const char c : fraction) {
    if (!is_digit(c)) return std::nullopt;
    ns += (c - '0') * scale;
    scale /= 10;
  }
  return s * 1'000'000'000 + ns;
}

std::optional<std::uint16_t> parse_hex16(std::string_view text) {
  if (text.empty() || text.size() > 4) return std::nullopt;
  unsigned value = 0;
  for (const char c : text) {
    unsigned digit;
    if (is_digit(c)) {
      digit = static_cast<unsigned>(c - '0');
    } else if (c >= 'a' && c <= 'f') {
      digit = static_cast<unsigned>(c - 'a' + 10);
    } else if (c >= 'A' && c <= 'F') {
      digit = static_cast<unsigned>(c - 'A' + 10);
    } else {
      return std::nullopt;
    }
    value = value * 16 + digit;
  }
  return static_cast<std::uint16_t>(value);
}

// Base 10 always: evemu pads values with zeros ("-013"), which a C-style
// parser would take for octal.
enum class IntError { kSyntax, kRange };
std::variant<std::int32_t, IntError> parse_decimal32(std::string_view text) {
  bool negative = false;
  if (!text.empty() && (text.front() == '-' || text.front() == '+')) {
    negative = text.front() == '-';
    text.remove_prefix(1);
  }
  if (text.empty()) return IntError::kSyntax;
  std::int64_t magnitude = 0;
  for (const char c : text) {
    if (!is_digit(c)) return IntError::kSyntax;
    magnitude = magnitude * 10 + (c - '0');
    if (magnitude > std::int64_t{1} << 32) magnitude = std::int64_t{1} << 32;  // saturate
  }
  const std::int64_t value = negative ? -magnitude : magnitude;
  if (value < std::numeric_limits<std::int32_t>::min() ||
      value > std::numeric_limits<std::int32_t>::max()) {
    return IntError::kRange;
  }
  return static_cast<std::int32_t>(value);
}

// "X:" with an upper-case letter: a device description line (N, I, P, B,
// A, L, S...), which motion does not need.
bool is_description(std::string_view line) {
  return line.size() >= 2 && line[0] >= 'A' && line[0] <= 'Z' && line[1] == ':';
}

// A line reader that knows where it is, for errors.
class LineFile {
 public:
  explicit LineFile(const std::filesystem::path& path) : name_(path.string()), in_(path) {
    if (!in_) throw Error(fmt::format("{}: cannot open", name_));
  }
  /// The next line without its end ('\r' of CRLF files dropped).
  std::optional<std::string_view> next() {
    // std::getline() with the CSV reader's bound: a file without line
    // ends (/dev/zero) is refused after kMaxLineBytes, not read whole.
    buffer_.clear();
    std::streambuf& in = *in_.rdbuf();
    bool any = false;
    for (int c = in.sbumpc(); c != std::char_traits<char>::eof(); c = in.sbumpc()) {
      any = true;
      if (c == '\n') break;
      if (buffer_.size() == kMaxLineBytes) {
        throw Error(fmt::format("{}:{}: line longer than {} bytes: not an evemu recording", name_,
                                line_ + 1, kMaxLineBytes));
      }
      buffer_.push_back(static_cast<char>(c));
    }
    if (!any) return std::nullopt;
    ++line_;
    if (!buffer_.empty() && buffer_.back() == '\r') buffer_.pop_back();
    return std::string_view(buffer_);
  }
  [[noreturn]] void fail(std::string_view what) const {
    throw Error(fmt::format("{}:{}: {}", name_, line_, what));
  }
  const std::string& name() const { return name_; }

 private:
  std::string name_;
  std::ifstream in_;
  std::string buffer_;
  std::size_t line_ = 0;
};

std::string device_name(std::string_view line) { return std::string(trim(line.substr(2))); }

// The .desc of an old-style recording: description and comments only.
std::string read_description(const std::filesystem::path& path) {
  LineFile file(path);
  std::string device;
  while (const auto line = file.next()) {
    const std::string_view text = trim(*line);
    if (text.empty() || text.front() == '#') continue;
    if (text.starts_with("E:")) {
      file.fail("event line in a device description (events belong in the .events file)");
    }
    if (!is_description(text)) file.fail(fmt::format("not an evemu line: '{}'", quote(text)));
    if (text.starts_with("N:")) device = device_name(text);
  }
  return device;
}

// One recording: its events, grouped into motion frames.
class Recording {
 public:
  explicit Recording(const EvemuInput& input) {
    namespace fs = std::filesystem;
    const auto exists = [](const fs::path& p) {
      std::error_code ec;
      return fs::exists(p, ec);
    };
    fs::path given = input.file;
    // The common stem of an old-style pair ("mouse" for mouse.desc and
    // mouse.events) names the pair too.
    if (!exists(given) && exists(given.string() + ".events")) given += ".events";
    fs::path events = given;
    std::optional<fs::path> description;
    if (given.extension() == ".desc") {
      description = given;
      events = fs::path(given).replace_extension(".events");
      if (!exists(events)) {
        throw Error(fmt::format("{}: no events file '{}' beside this description", given.string(),
                                events.string()));
      }
    } else if (given.extension() == ".events") {
      const auto beside = fs::path(given).replace_extension(".desc");
      if (exists(beside)) description = beside;
    }
    if (description) stats_.device = read_description(*description);
    stats_.events = events;
    file_.emplace(events);
    peeked_ = read_event();
    if (!peeked_) throw Error(fmt::format("{}: no events", file_->name()));
  }

  std::int64_t first_time_ns() const { return first_ns_; }
  const EvemuStats& stats() const { return stats_; }

  /// The next frame with motion, nullopt at the end of the file.
  std::optional<Frame> next_frame() {
    Frame frame;
    bool motion = false;
    while (const auto event = take_event()) {
      frame.time_ns = event->time_ns;
      if (event->type == kEvRel && (event->code == kRelX || event->code == kRelY)) {
        (event->code == kRelX ? frame.dx : frame.dy) += event->value;
        (event->code == kRelX ? stats_.sum_dx : stats_.sum_dy) += event->value;
        motion = motion || event->value != 0;
      } else if (event->type == kEvSyn && event->code == kSynReport) {
        if (motion) {
          ++stats_.frames;
          return frame;
        }
        frame = Frame{};
      } else if (event->type == kEvSyn && event->code == kSynDropped) {
        ++stats_.dropped;
      }
    }
    if (motion) {
      stats_.unterminated = true;
      ++stats_.frames;
      return frame;
    }
    return std::nullopt;
  }

 private:
  std::optional<Event> take_event() {
    auto event = peeked_;
    if (event) peeked_ = read_event();
    return event;
  }

  std::optional<Event> read_event() {
    while (const auto line = file_->next()) {
      const std::string_view text = trim(*line);
      if (text.empty() || text.front() == '#') continue;
      if (text.starts_with("E:")) return parse_event(text.substr(2));
      if (!is_description(text)) file_->fail(fmt::format("not an evemu line: '{}'", quote(text)));
      if (text.starts_with("N:") && stats_.device.empty()) stats_.device = device_name(text);
    }
    return std::nullopt;
  }

  Event parse_event(std::string_view text) {
    const auto fields = fields_of(text);
    if (fields.size() < 4) {
      file_->fail(fmt::format("event line has {} of its 4 fields (time, type, code, value)",
                              fields.size()));
    }
    if (fields.size() > 4) {
      file_->fail(fmt::format("unexpected '{}' after the event value", quote(fields[4])));
    }
    Event event;
    const auto time = parse_time_ns(fields[0]);
    if (!time) {
      file_->fail(fmt::format("event time '{}' is not SECONDS.FRACTION (at most 9 fraction digits)",
                              quote(fields[0])));
    }
    event.time_ns = *time;
    const auto type = parse_hex16(fields[1]);
    if (!type) file_->fail(fmt::format("event type '{}' is not 1-4 hex digits", quote(fields[1])));
    event.type = *type;
    const auto code = parse_hex16(fields[2]);
    if (!code) file_->fail(fmt::format("event code '{}' is not 1-4 hex digits", quote(fields[2])));
    event.code = *code;
    const auto value = parse_decimal32(fields[3]);
    if (const auto* error = std::get_if<IntError>(&value)) {
      file_->fail(
          *error == IntError::kSyntax
              ? fmt::format("event value '{}' is not a base-10 integer", quote(fields[3]))
              : fmt::format("event value '{}' is outside the 32-bit range", quote(fields[3])));
    }
    event.value = std::get<std::int32_t>(value);
    if (stats_.events_read > 0 && event.time_ns < last_ns_) {
      file_->fail(fmt::format("event time {} is before the previous event's {}", fields[0],
                              format_ns(last_ns_)));
    }
    if (stats_.events_read == 0) first_ns_ = event.time_ns;
    last_ns_ = event.time_ns;
    ++stats_.events_read;
    return event;
  }

  static std::string format_ns(std::int64_t ns) {
    return fmt::format("{}.{:06}", ns / 1'000'000'000, (ns % 1'000'000'000) / 1000);
  }

  std::optional<LineFile> file_;
  EvemuStats stats_;
  std::optional<Event> peeked_;
  std::int64_t first_ns_ = 0;
  std::int64_t last_ns_ = 0;
};

}  // namespace

struct EvemuReader::Impl {
  std::vector<Recording> recordings;
  std::vector<std::optional<Frame>> pending;  // next frame of each recording
  std::int64_t origin_ns = 0;
};

EvemuReader::EvemuReader(const std::vector<EvemuInput>& inputs) : impl_(std::make_unique<Impl>()) {
  if (inputs.empty()) throw Error("evemu: no recordings given");
  impl_->recordings.reserve(inputs.size());
  for (const auto& input : inputs) impl_->recordings.emplace_back(input);
  impl_->origin_ns = std::min_element(impl_->recordings.begin(), impl_->recordings.end(),
                                      [](const Recording& a, const Recording& b) {
                                        return a.first_time_ns() < b.first_time_ns();
                                      })
                         ->first_time_ns();
  for (auto& recording : impl_->recordings) impl_->pending.push_back(recording.next_frame());
}

EvemuReader::~EvemuReader() = default;

double EvemuReader::start_time() { return 0.0; }

std::optional<SensorRow> EvemuReader::next() {
  auto& pending = impl_->pending;
  std::optional<std::size_t> best;
  for (std::size_t i = 0; i < pending.size(); ++i) {
    if (pending[i] && (!best || pending[i]->time_ns < pending[*best]->time_ns)) best = i;
  }
  if (!best) return std::nullopt;
  const Frame frame = *pending[*best];
  pending[*best] = impl_->recordings[*best].next_frame();
  SensorRow row;
  // Integer nanoseconds first: the difference is exact, and one division
  // rounds it once.
  row.t = static_cast<double>(frame.time_ns - impl_->origin_ns) / 1e9;
  row.sensor = static_cast<int>(*best);
  row.counts = {static_cast<double>(frame.dx), static_cast<double>(frame.dy)};
  return row;
}

const EvemuStats& EvemuReader::stats(int input) const {
  return impl_->recordings.at(static_cast<std::size_t>(input)).stats();
}

}  // namespace moa::io
