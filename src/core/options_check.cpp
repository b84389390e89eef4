#include "moa/core/options_check.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace moa {

void InvalidOption::append(std::string_view text) {
  for (const char c : text) {
    if (size_ + 1 >= kCapacity) break;
    text_[size_++] = c;
  }
  text_[size_] = '\0';
}

void InvalidOption::append_integer(long long x) {
  if (x < 0) append("-");
  // Digits of |x| from the last; unsigned so that the most negative value fits.
  unsigned long long u =
      x < 0 ? 0ULL - static_cast<unsigned long long>(x) : static_cast<unsigned long long>(x);
  std::array<char, 24> digits{};
  std::size_t n = 0;
  do {
    digits[n++] = static_cast<char>('0' + u % 10);
    u /= 10;
  } while (u != 0);
  while (n > 0) append(std::string_view(&digits[--n], 1));
}

void InvalidOption::append_number(double x) {
  if (std::isnan(x)) return append("nan");
  if (std::isinf(x)) return append(x > 0 ? "inf" : "-inf");
  // Whole numbers as they are (a port, a buffer size): 16777216, not 1.67772e+07.
  if (std::fabs(x) < 1e15 && std::floor(x) == x) return append_integer(std::llround(x));
  if (x < 0) append("-");
  const double a = std::fabs(x);
  // Six significant digits d (100000 <= d < 1000000) with a ~ d 10^(e - 5).
  const auto scaled = [a](int e) {
    const int k = e - 5;
    return std::llround(k >= 0 ? a / std::pow(10.0, k) : a * std::pow(10.0, -k));
  };
  int e = static_cast<int>(std::floor(std::log10(a)));
  long long d = scaled(e);
  if (d >= 1000000) d = scaled(++e);
  if (d < 100000) d = scaled(--e);
  std::array<char, 6> s{};
  for (int i = 5; i >= 0; --i, d /= 10)
    s[static_cast<std::size_t>(i)] = static_cast<char>('0' + d % 10);
  int n = 6;  // significant digits, trailing zeros dropped
  while (n > 1 && s[static_cast<std::size_t>(n - 1)] == '0') --n;
  const auto digits = [&s](int from, int to) {
    return std::string_view(s.data() + from, static_cast<std::size_t>(to - from));
  };
  if (e >= -4 && e < 6) {
    if (e >= 0) {
      append(digits(0, std::min(n, e + 1)));
      for (int i = n; i < e + 1; ++i) append("0");
      if (n > e + 1) {
        append(".");
        append(digits(e + 1, n));
      }
    } else {
      append("0.");
      for (int i = 0; i < -e - 1; ++i) append("0");
      append(digits(0, n));
    }
    return;
  }
  append(digits(0, 1));
  if (n > 1) {
    append(".");
    append(digits(1, n));
  }
  append(e < 0 ? "e-" : "e+");
  if (std::abs(e) < 10) append("0");
  append_integer(std::abs(e));
}

void InvalidOption::prefix(std::string_view parent) {
  if (parent.empty()) return;
  InvalidOption out;
  out.append(parent);
  out.append(".");
  out.append(view());
  *this = out;
}

namespace {
// "field: must be " : the head of every message.
InvalidOption must_be(const char* field) {
  InvalidOption e;
  e.append(field);
  e.append(": must be ");
  return e;
}
}  // namespace

void OptionsCheck::refuse(InvalidOption e, double value) {
  e.append(", is ");
  e.append_number(value);
  error_ = e;
}

bool OptionsCheck::finite(const char* field, double x) {
  if (error_) return false;
  if (std::isfinite(x)) return true;
  InvalidOption e = must_be(field);
  e.append("finite");
  refuse(e, x);
  return false;
}

void OptionsCheck::compare(const char* field, double x, bool ok, const char* op,
                           const char* bound_name, double bound) {
  if (ok) return;
  InvalidOption e = must_be(field);
  e.append(op);
  if (bound_name != nullptr) {
    e.append(bound_name);
    e.append(" (");
    e.append_number(bound);
    e.append(")");
  } else {
    e.append_number(bound);
  }
  refuse(e, x);
}

void OptionsCheck::interval(const char* field, double x, bool ok, const char* open_bracket,
                            double lo, double hi, const char* close_bracket) {
  if (ok) return;
  InvalidOption e = must_be(field);
  e.append("in ");
  e.append(open_bracket);
  e.append_number(lo);
  e.append(", ");
  e.append_number(hi);
  e.append(close_bracket);
  refuse(e, x);
}

OptionsCheck& OptionsCheck::greater(const char* field, double x, double lo) {
  if (finite(field, x)) compare(field, x, x > lo, "> ", nullptr, lo);
  return *this;
}

OptionsCheck& OptionsCheck::at_least(const char* field, double x, double lo) {
  if (finite(field, x)) compare(field, x, x >= lo, ">= ", nullptr, lo);
  return *this;
}

OptionsCheck& OptionsCheck::at_most(const char* field, double x, double hi) {
  if (finite(field, x)) compare(field, x, x <= hi, "<= ", nullptr, hi);
  return *this;
}

OptionsCheck& OptionsCheck::positive_or_infinite(const char* field, double x) {
  if (!error_) compare(field, x, x > 0.0, "> ", nullptr, 0.0);
  return *this;
}

OptionsCheck& OptionsCheck::open(const char* field, double x, double lo, double hi) {
  if (finite(field, x)) interval(field, x, x > lo && x < hi, "(", lo, hi, ")");
  return *this;
}

OptionsCheck& OptionsCheck::closed(const char* field, double x, double lo, double hi) {
  if (finite(field, x)) interval(field, x, x >= lo && x <= hi, "[", lo, hi, "]");
  return *this;
}

OptionsCheck& OptionsCheck::at_least(const char* field, long long x, long long lo) {
  if (error_ || x >= lo) return *this;
  InvalidOption e = must_be(field);
  e.append(">= ");
  e.append_integer(lo);
  e.append(", is ");
  e.append_integer(x);
  error_ = e;
  return *this;
}

OptionsCheck& OptionsCheck::at_most_named(const char* field, double x, const char* bound_name,
                                          double bound) {
  if (finite(field, x)) compare(field, x, x <= bound, "<= ", bound_name, bound);
  return *this;
}

void OptionsCheck::component(const char* field, int i, double x, bool strict) {
  InvalidOption name;
  name.append(field);
  name.append("[");
  name.append_integer(i);
  name.append("]");
  if (strict) {
    greater(name.message(), x, 0.0);
  } else {
    at_least(name.message(), x, 0.0);
  }
}

OptionsCheck& OptionsCheck::require(bool ok, const char* field, const char* bound, double value) {
  if (error_ || ok) return *this;
  InvalidOption e = must_be(field);
  e.append(bound);
  refuse(e, value);
  return *this;
}

OptionsCheck& OptionsCheck::require(bool ok, const char* field, const char* reason) {
  if (error_ || ok) return *this;
  InvalidOption e;
  e.append(field);
  e.append(": ");
  e.append(reason);
  error_ = e;
  return *this;
}

OptionsCheck& OptionsCheck::nested(const char* member, const OptionCheck& check) {
  if (error_ || !check) return *this;
  error_ = check;
  error_->prefix(member);
  return *this;
}

}  // namespace moa
