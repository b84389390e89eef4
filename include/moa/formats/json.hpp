// One small JSON writer for everything moa prints as JSON (experiments,
// evaluate, calibrate): keys in the order written, numbers as the shortest
// text that reads back as the same double, non-finite numbers as null.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace moa::io {

class JsonWriter {
 public:
  JsonWriter& begin_object();
  JsonWriter& end_object();
  JsonWriter& begin_array();
  JsonWriter& end_array();
  /// The next member's name (inside an object).
  JsonWriter& key(std::string_view name);
  JsonWriter& value(double x);
  JsonWriter& value(std::int64_t x);
  JsonWriter& value(std::uint64_t x);
  JsonWriter& value(int x) { return value(static_cast<std::int64_t>(x)); }
  JsonWriter& value(bool x);
  JsonWriter& value(std::string_view text);
  JsonWriter& value(const char* text) { return value(std::string_view(text)); }
  JsonWriter& null();
  /// A value already written as JSON (an object from another writer).
  JsonWriter& raw(std::string_view json);
  /// key(name).value(x)
  template <class T>
  JsonWriter& member(std::string_view name, const T& x) {
    key(name);
    return value(x);
  }
  const std::string& str() const { return out_; }

 private:
  void separate();
  std::string out_;
  std::vector<bool> first_;  ///< per open container: nothing written in it yet
  bool after_key_ = false;
};

/// `text` as a JSON string literal, quotes included.
std::string json_string(std::string_view text);

}  // namespace moa::io
