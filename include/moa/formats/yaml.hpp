// Internal to moa's I/O: the one strict YAML reader under the robot config
// (config.hpp) and the simulator's scenarios (sim/scenario.hpp), so that
// both refuse the same things in the same words:
//   "SOURCE:LINE: [LABEL: ]key 'path.key': what is wrong".
//
// Loading is guarded (docs/reliability.md): Debian's yaml-cpp 0.7 LoadAll()
// never returns on a document that starts with a token its parser neither
// uses nor consumes (',' outside a flow collection: ",", ",a", "&a ,",
// "--- ,"): it appends empty documents forever, memory growing without
// bound. So the text is read as a stream of events first, at most two
// documents deep ("one, or more than one"), refused beyond kMaxYamlBytes or
// kMaxYamlDepth levels of nesting, and only then built into nodes.
//
// Values are strict: unknown and duplicate keys are errors, numbers go
// through io::parse_number (finite, the same text the same double),
// booleans are YAML 1.2 core ("yes" is not one), integers are decimal
// digits within a stated range.
#pragma once

#include <yaml-cpp/yaml.h>

#include <cstddef>
#include <initializer_list>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace moa::io {

/// Inputs larger than this are refused before parsing (a config or a
/// scenario is a few kB).
inline constexpr std::size_t kMaxYamlBytes = 1 << 20;
/// Deeper nesting of lists and maps is refused (the deepest the readers use is 4).
inline constexpr int kMaxYamlDepth = 32;

/// The one document of `text`, a null node when there is none; throws
/// io::Error "SOURCE:LINE: invalid YAML: ...", "SOURCE: expected one YAML
/// document, found more", "SOURCE: larger than ...", "SOURCE:LINE: nested
/// deeper than ...".
YAML::Node load_yaml(std::string_view text, std::string_view source);

/// "nothing", "a list", "a map" or the quoted scalar, for messages.
std::string describe_kind(const YAML::Node& node);

/// Where nodes come from, for messages: "SOURCE:LINE: ".
class YamlSource {
 public:
  explicit YamlSource(std::string_view name) : name_(name) {}
  [[noreturn]] void fail(const YAML::Node& at, std::string_view what) const;
  [[noreturn]] void fail(std::string_view what) const;
  const std::string& name() const { return name_; }

 private:
  std::string name_;
};

/// A YAML map whose keys are all known and each present once. Values are
/// read by key; messages name the key by its dotted path ("motion.max_speed"),
/// after `label` when there is one ("sensor 'm1': key 'yaw': ...").
class YamlFields {
 public:
  YamlFields(const YamlSource& source, const YAML::Node& map, std::string path,
             std::initializer_list<std::string_view> allowed, std::string label = {});

  bool has(std::string_view key) const { return values_.contains(key); }
  std::optional<YAML::Node> get(std::string_view key) const;
  /// The value; "missing key" if absent.
  YAML::Node required(std::string_view key) const;

  [[noreturn]] void fail(std::string_view key, std::string_view what) const;
  [[noreturn]] void fail_at(const YAML::Node& at, std::string_view key,
                            std::string_view what) const;
  /// An error about the map as a whole: "[LABEL: ]what".
  [[noreturn]] void fail_here(std::string_view what) const;

  /// The key's dotted path.
  std::string full(std::string_view key) const;
  const YamlSource& source() const { return source_; }
  const YAML::Node& node() const { return map_; }
  /// What every message starts with ("sensor 'm1'"), for a nested map's fields.
  const std::string& label() const { return label_; }

  // Typed values; the overloads with a fallback return it when the key is absent.
  double number(std::string_view key) const;
  double number(std::string_view key, double fallback) const;
  double positive(std::string_view key) const;
  double positive(std::string_view key, double fallback) const;
  double non_negative(std::string_view key, double fallback) const;
  /// Within [0, 1].
  double fraction(std::string_view key, double fallback) const;
  /// Within [min, max] (inclusive); for a number with a physical upper bound.
  double bounded(std::string_view key, double min, double max) const;
  double bounded(std::string_view key, double min, double max, double fallback) const;
  /// Decimal digits with an optional sign, within [min, max].
  long integer(std::string_view key, long min, long max) const;
  std::string text(std::string_view key) const;
  bool boolean(std::string_view key, bool fallback) const;
  /// A list of numbers, of `size` elements when size > 0.
  std::vector<double> numbers(std::string_view key, std::size_t size = 0) const;
  std::vector<double> to_numbers(std::string_view key, const YAML::Node& node,
                                 std::size_t size) const;
  /// One of `choices`.
  std::string choice(std::string_view key, std::initializer_list<std::string_view> choices) const;
  double to_number(std::string_view key, const YAML::Node& node) const;

 private:
  std::string prefix() const;

  const YamlSource& source_;
  YAML::Node map_;
  std::string path_;
  std::string label_;
  std::map<std::string, std::pair<YAML::Node, YAML::Node>, std::less<>> values_;
};

}  // namespace moa::io
