// A small JSON reader for tests: parses the one object a moa command prints
// with --json into a tree, so a test can check figures by key. Strict
// enough for that (RFC 8259 values; \uXXXX escapes other than ASCII are kept
// as written); throws std::runtime_error with the offset of bad input.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace moa::test {

class JsonValue {
 public:
  using Array = std::vector<JsonValue>;
  using Object = std::map<std::string, JsonValue, std::less<>>;

  static JsonValue parse(std::string_view text);

  bool is_null() const { return std::holds_alternative<std::monostate>(value_); }
  double number() const;
  const std::string& string() const;
  bool boolean() const;
  const Array& array() const;
  const Object& object() const;
  /// The member `key` of an object; throws if absent.
  const JsonValue& operator[](std::string_view key) const;
  /// Element i of an array; throws if out of range.
  const JsonValue& operator[](std::size_t i) const;
  /// The array's elements as numbers.
  std::vector<double> numbers() const;

 private:
  friend class JsonParser;
  std::variant<std::monostate, bool, double, std::string, std::shared_ptr<Array>,
               std::shared_ptr<Object>>
      value_;
};

}  // namespace moa::test
