#include "moa/formats/yaml.hpp"

#include <fmt/format.h>
#include <yaml-cpp/eventhandler.h>

#include <algorithm>
#include <charconv>
#include <sstream>
#include <system_error>

#include "moa/formats/csv.hpp"
#include "moa/formats/error.hpp"

namespace moa::io {
namespace {

// Sees the events of a parse and builds nothing: stops it (by throwing)
// when lists and maps nest deeper than kMaxYamlDepth.
class DepthCheck : public YAML::EventHandler {
 public:
  struct TooDeep {
    YAML::Mark mark;
  };
  void OnDocumentStart(const YAML::Mark& mark) override {
    depth_ = 0;
    if (++documents_ == 2) second_ = mark;
  }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnAlias(const YAML::Mark&, YAML::anchor_t) override { content(); }
  void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t,
                const std::string&) override {
    content();
  }
  void OnSequenceStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t,
                       YAML::EmitterStyle::value) override {
    content();
    enter(mark);
  }
  void OnSequenceEnd() override { --depth_; }
  void OnMapStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t,
                  YAML::EmitterStyle::value) override {
    content();
    enter(mark);
  }
  void OnMapEnd() override { --depth_; }

  /// Where the second document starts (valid once two were seen).
  const YAML::Mark& second() const { return second_; }
  /// Whether the first document held anything but an empty node.
  bool first_has_content() const { return first_has_content_; }

 private:
  void content() {
    if (documents_ == 1) first_has_content_ = true;
  }
  void enter(const YAML::Mark& mark) {
    if (++depth_ > kMaxYamlDepth) throw TooDeep{mark};
  }
  int depth_ = 0;
  int documents_ = 0;
  bool first_has_content_ = false;
  YAML::Mark second_ = YAML::Mark::null_mark();
};

[[noreturn]] void fail_yaml(std::string_view source, const YAML::Exception& e) {
  if (e.mark.is_null()) throw Error(printable(fmt::format("{}: invalid YAML: {}", source, e.msg)));
  throw Error(printable(fmt::format("{}:{}: invalid YAML: {}", source, e.mark.line + 1, e.msg)));
}

}  // namespace

YAML::Node load_yaml(std::string_view text, std::string_view source) {
  if (text.size() > kMaxYamlBytes) {
    throw Error(fmt::format("{}: larger than {} bytes ({} bytes): not a moa YAML file", source,
                            kMaxYamlBytes, text.size()));
  }
  const std::string input(text);
  try {
    // At most two documents are asked for: LoadAll() would loop here.
    std::istringstream in(input);
    YAML::Parser parser(in);
    DepthCheck check;
    if (parser.HandleNextDocument(check) && parser.HandleNextDocument(check)) {
      const YAML::Mark& at = check.second();
      const auto pos = static_cast<std::size_t>(std::max(0, at.pos));
      if (!check.first_has_content() && pos < input.size() && input[pos] == ',') {
        // What LoadAll() would loop on: nothing parses, nothing is consumed.
        throw Error(fmt::format("{}:{}: invalid YAML: ',' outside a [list] or {{map}}", source,
                                at.line + 1));
      }
      throw Error(
          fmt::format("{}:{}: expected one YAML document, found another", source, at.line + 1));
    }
    return YAML::Load(input);
  } catch (const DepthCheck::TooDeep& deep) {
    throw Error(fmt::format("{}:{}: lists and maps nested deeper than {} levels", source,
                            deep.mark.line + 1, kMaxYamlDepth));
  } catch (const YAML::Exception& e) {
    fail_yaml(source, e);
  }
}

std::string describe_kind(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Null:
    case YAML::NodeType::Undefined:
      return "nothing";
    case YAML::NodeType::Sequence:
      return "a list";
    case YAML::NodeType::Map:
      return "a map";
    default:
      return fmt::format("'{}'", excerpt(node.Scalar()));
  }
}

void YamlSource::fail(const YAML::Node& at, std::string_view what) const {
  const YAML::Mark mark = at.Mark();
  if (mark.is_null()) fail(what);
  throw Error(printable(fmt::format("{}:{}: {}", name_, mark.line + 1, what)));
}

void YamlSource::fail(std::string_view what) const {
  throw Error(printable(fmt::format("{}: {}", name_, what)));
}

YamlFields::YamlFields(const YamlSource& source, const YAML::Node& map, std::string path,
                       std::initializer_list<std::string_view> allowed, std::string label)
    : source_(source), map_(map), path_(std::move(path)), label_(std::move(label)) {
  if (!map.IsMap()) {
    const std::string where = path_.empty() ? "" : fmt::format("key '{}': ", path_);
    source.fail(map,
                fmt::format("{}{}expected a map, found {}", prefix(), where, describe_kind(map)));
  }
  for (const auto& entry : map) {
    if (!entry.first.IsScalar()) {
      source.fail(entry.first, prefix() + "a key is not a plain name");
    }
    const std::string& key = entry.first.Scalar();
    if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
      std::string known;
      for (const auto k : allowed) known += (known.empty() ? "" : ", ") + std::string(k);
      source.fail(entry.first, fmt::format("{}unknown key '{}' (known here: {})", prefix(),
                                           excerpt(full(key)), known));
    }
    if (!values_.emplace(key, entry).second) {
      source.fail(entry.first, fmt::format("{}duplicate key '{}'", prefix(), excerpt(full(key))));
    }
  }
}

std::optional<YAML::Node> YamlFields::get(std::string_view key) const {
  const auto it = values_.find(key);
  if (it == values_.end()) return std::nullopt;
  return it->second.second;
}

YAML::Node YamlFields::required(std::string_view key) const {
  const auto node = get(key);
  if (!node) source_.fail(map_, fmt::format("{}missing key '{}'", prefix(), full(key)));
  return *node;
}

void YamlFields::fail(std::string_view key, std::string_view what) const {
  const auto it = values_.find(key);
  const YAML::Node at = it == values_.end() ? map_ : it->second.second;
  fail_at(at, key, what);
}

void YamlFields::fail_at(const YAML::Node& at, std::string_view key, std::string_view what) const {
  source_.fail(at, fmt::format("{}key '{}': {}", prefix(), full(key), what));
}

void YamlFields::fail_here(std::string_view what) const {
  source_.fail(map_, fmt::format("{}{}", prefix(), what));
}

std::string YamlFields::full(std::string_view key) const {
  return path_.empty() ? std::string(key) : path_ + "." + std::string(key);
}

std::string YamlFields::prefix() const { return label_.empty() ? "" : label_ + ": "; }

double YamlFields::number(std::string_view key) const { return to_number(key, required(key)); }

double YamlFields::number(std::string_view key, double fallback) const {
  return has(key) ? number(key) : fallback;
}

double YamlFields::positive(std::string_view key) const {
  const double v = number(key);
  if (!(v > 0.0)) fail(key, fmt::format("must be > 0 (found {})", v));
  return v;
}

double YamlFields::positive(std::string_view key, double fallback) const {
  return has(key) ? positive(key) : fallback;
}

double YamlFields::non_negative(std::string_view key, double fallback) const {
  if (!has(key)) return fallback;
  const double v = number(key);
  if (v < 0.0) fail(key, fmt::format("must be >= 0 (found {})", v));
  return v;
}

double YamlFields::fraction(std::string_view key, double fallback) const {
  return has(key) ? bounded(key, 0.0, 1.0) : fallback;
}

double YamlFields::bounded(std::string_view key, double min, double max) const {
  const double v = number(key);
  if (v < min || v > max) fail(key, fmt::format("must be within [{}, {}] (found {})", min, max, v));
  return v;
}

double YamlFields::bounded(std::string_view key, double min, double max, double fallback) const {
  return has(key) ? bounded(key, min, max) : fallback;
}

long YamlFields::integer(std::string_view key, long min, long max) const {
  const YAML::Node node = required(key);
  if (!node.IsScalar()) {
    fail(key, fmt::format("expected an integer, found {}", describe_kind(node)));
  }
  const std::string& text = node.Scalar();
  const char* begin = text.data();
  if (!text.empty() && text.front() == '+') ++begin;
  long value = 0;
  const auto [end, ec] = std::from_chars(begin, text.data() + text.size(), value);
  if (ec != std::errc{} || end != text.data() + text.size() || begin == end) {
    fail(key, fmt::format("'{}' is not an integer", excerpt(text)));
  }
  if (value < min || value > max) {
    fail(key, fmt::format("must be within [{}, {}] (found {})", min, max, value));
  }
  return value;
}

std::string YamlFields::text(std::string_view key) const {
  const YAML::Node node = required(key);
  if (!node.IsScalar()) fail(key, fmt::format("expected text, found {}", describe_kind(node)));
  return node.Scalar();
}

bool YamlFields::boolean(std::string_view key, bool fallback) const {
  if (!has(key)) return fallback;
  const YAML::Node node = required(key);
  if (node.IsScalar()) {
    const std::string& t = node.Scalar();
    if (t == "true" || t == "True" || t == "TRUE") return true;
    if (t == "false" || t == "False" || t == "FALSE") return false;
  }
  fail(key, fmt::format("expected true or false, found {}", describe_kind(node)));
}

std::vector<double> YamlFields::numbers(std::string_view key, std::size_t size) const {
  return to_numbers(key, required(key), size);
}

std::vector<double> YamlFields::to_numbers(std::string_view key, const YAML::Node& node,
                                           std::size_t size) const {
  if (!node.IsSequence()) {
    fail_at(node, key, fmt::format("expected a list of numbers, found {}", describe_kind(node)));
  }
  if (size > 0 && node.size() != size) {
    fail_at(node, key, fmt::format("expected {} numbers, found {}", size, node.size()));
  }
  std::vector<double> out;
  for (const auto& item : node) out.push_back(to_number(key, item));
  return out;
}

std::string YamlFields::choice(std::string_view key,
                               std::initializer_list<std::string_view> choices) const {
  const std::string value = text(key);
  if (std::find(choices.begin(), choices.end(), value) == choices.end()) {
    std::string list;
    for (const auto c : choices) list += (list.empty() ? "" : ", ") + std::string(c);
    fail(key, fmt::format("'{}' is not one of: {}", excerpt(value), list));
  }
  return value;
}

double YamlFields::to_number(std::string_view key, const YAML::Node& node) const {
  if (!node.IsScalar()) {
    fail_at(node, key, fmt::format("expected a number, found {}", describe_kind(node)));
  }
  const auto parsed = parse_number(node.Scalar());
  if (const auto* error = std::get_if<std::string>(&parsed)) fail_at(node, key, *error);
  return std::get<double>(parsed);
}

}  // namespace moa::io
