#include "support/json_value.hpp"

#include <cctype>
#include <charconv>
#include <stdexcept>

namespace moa::test {

class JsonParser {
 public:
  explicit JsonParser(std::string_view text) : s_(text) {}

  JsonValue document() {
    JsonValue v = value(0);
    skip();
    if (p_ != s_.size()) fail("text after the value");
    return v;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error("JSON at offset " + std::to_string(p_) + ": " + what);
  }
  void skip() {
    while (p_ < s_.size() &&
           (s_[p_] == ' ' || s_[p_] == '\n' || s_[p_] == '\t' || s_[p_] == '\r')) {
      ++p_;
    }
  }
  bool take(char c) {
    skip();
    if (p_ < s_.size() && s_[p_] == c) {
      ++p_;
      return true;
    }
    return false;
  }
  void expect(char c) {
    if (!take(c)) fail(std::string("expected '") + c + "'");
  }
  bool word(std::string_view w) {
    if (s_.substr(p_, w.size()) != w) return false;
    p_ += w.size();
    return true;
  }
  std::string string() {
    expect('"');
    std::string out;
    while (p_ < s_.size() && s_[p_] != '"') {
      char c = s_[p_++];
      if (c == '\\') {
        if (p_ >= s_.size()) fail("unterminated escape");
        const char e = s_[p_++];
        switch (e) {
          case 'n':
            c = '\n';
            break;
          case 't':
            c = '\t';
            break;
          case 'r':
            c = '\r';
            break;
          case 'b':
            c = '\b';
            break;
          case 'f':
            c = '\f';
            break;
          case 'u':
            out += "\\u";
            continue;
          default:
            c = e;
        }
      }
      out += c;
    }
    if (p_ >= s_.size()) fail("unterminated string");
    ++p_;
    return out;
  }
  JsonValue value(int depth) {
    if (depth > 64) fail("nested too deeply");
    skip();
    if (p_ >= s_.size()) fail("expected a value");
    JsonValue v;
    const char c = s_[p_];
    if (c == '{') {
      ++p_;
      auto object = std::make_shared<JsonValue::Object>();
      if (!take('}')) {
        do {
          skip();
          std::string key = string();
          expect(':');
          (*object)[key] = value(depth + 1);
        } while (take(','));
        expect('}');
      }
      v.value_ = object;
    } else if (c == '[') {
      ++p_;
      auto array = std::make_shared<JsonValue::Array>();
      if (!take(']')) {
        do {
          array->push_back(value(depth + 1));
        } while (take(','));
        expect(']');
      }
      v.value_ = array;
    } else if (c == '"') {
      v.value_ = string();
    } else if (word("true")) {
      v.value_ = true;
    } else if (word("false")) {
      v.value_ = false;
    } else if (word("null")) {
      v.value_ = std::monostate{};
    } else {
      double x = 0.0;
      const auto [end, ec] = std::from_chars(s_.data() + p_, s_.data() + s_.size(), x);
      if (ec != std::errc{}) fail("expected a value");
      p_ = static_cast<std::size_t>(end - s_.data());
      v.value_ = x;
    }
    return v;
  }

  std::string_view s_;
  std::size_t p_ = 0;
};

JsonValue JsonValue::parse(std::string_view text) { return JsonParser(text).document(); }

namespace {
template <class T, class V>
const T& get(const V& v, const char* what) {
  const T* x = std::get_if<T>(&v);
  if (!x) throw std::runtime_error(std::string("JSON value is not ") + what);
  return *x;
}
}  // namespace

double JsonValue::number() const { return get<double>(value_, "a number"); }
const std::string& JsonValue::string() const { return get<std::string>(value_, "a string"); }
bool JsonValue::boolean() const { return get<bool>(value_, "a boolean"); }
const JsonValue::Array& JsonValue::array() const {
  return *get<std::shared_ptr<Array>>(value_, "an array");
}
const JsonValue::Object& JsonValue::object() const {
  return *get<std::shared_ptr<Object>>(value_, "an object");
}
const JsonValue& JsonValue::operator[](std::string_view key) const {
  const auto& o = object();
  const auto it = o.find(key);
  if (it == o.end()) throw std::runtime_error("JSON object has no key '" + std::string(key) + "'");
  return it->second;
}
const JsonValue& JsonValue::operator[](std::size_t i) const {
  const auto& a = array();
  if (i >= a.size())
    throw std::runtime_error("JSON array index " + std::to_string(i) + " out of range");
  return a[i];
}
std::vector<double> JsonValue::numbers() const {
  std::vector<double> out;
  for (const auto& v : array()) out.push_back(v.number());
  return out;
}

}  // namespace moa::test
