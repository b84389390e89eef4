// The checks every options struct's validate() is written with, in the
// manner of Ceres' Options::IsValid: the first field out of its bounds gives
// one message naming the field's path as the user sees it, the bound it
// breaks and its value:
//   "consensus.health.drift_shift: must be > 0, is 0"
//   "ekf.scale_sd[1]: must be > 0, is -0.5"
//   "rate: must be finite, is nan"
// A real field is always required to be finite (NaN and infinities are
// refused with "must be finite") unless the check says otherwise.
//
// Heap-free (a fixed buffer, no stdio): the core's options are checked on
// the microcontroller too. A nested struct's validate() names its fields
// relative to itself; the enclosing validate() prefixes its member's path
// (OptionsCheck::nested), so each bound is written once, in the struct
// that owns the field.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <optional>
#include <string_view>

namespace moa {

/// One refused option: "path: must be BOUND, is VALUE", in a fixed buffer.
class InvalidOption {
 public:
  static constexpr std::size_t kCapacity = 192;  ///< characters, with the terminating 0

  /// The message, 0-terminated (cut at kCapacity - 1 characters).
  const char* message() const { return text_.data(); }
  std::string_view view() const { return {text_.data(), size_}; }

  void append(std::string_view text);
  /// A whole number below 1e15 in magnitude as an integer, any other x as
  /// printf's %.6g would write it ("nan", "inf", "-inf").
  void append_number(double x);
  void append_integer(long long x);
  /// Prefixes `parent` and a '.' to the path: "drift_shift: ..." becomes
  /// "consensus.health.drift_shift: ...".
  void prefix(std::string_view parent);

 private:
  std::array<char, kCapacity> text_{};
  std::size_t size_ = 0;
};

/// What validate() returns: nullopt when the options can be used.
using OptionCheck = std::optional<InvalidOption>;

/// Collects the first failure of a sequence of checks; the later checks are
/// skipped once one failed. `field` is a path relative to the struct being
/// validated ("drift_shift", "noise.speed_cap").
class OptionsCheck {
 public:
  /// x > lo.
  OptionsCheck& greater(const char* field, double x, double lo);
  /// x >= lo.
  OptionsCheck& at_least(const char* field, double x, double lo);
  /// x > 0 (infinity allowed: "no limit").
  OptionsCheck& positive_or_infinite(const char* field, double x);
  OptionsCheck& positive(const char* field, double x) { return greater(field, x, 0.0); }
  OptionsCheck& non_negative(const char* field, double x) { return at_least(field, x, 0.0); }
  /// x <= hi.
  OptionsCheck& at_most(const char* field, double x, double hi);
  /// lo < x < hi.
  OptionsCheck& open(const char* field, double x, double lo, double hi);
  /// lo <= x <= hi.
  OptionsCheck& closed(const char* field, double x, double lo, double hi);
  /// x >= lo, integers.
  OptionsCheck& at_least(const char* field, long long x, long long lo);
  OptionsCheck& at_least(const char* field, int x, int lo) {
    return at_least(field, static_cast<long long>(x), static_cast<long long>(lo));
  }
  /// x <= the bound named `bound_name` (of value `bound`):
  /// "must be <= 61 periods (0.61), is 1".
  OptionsCheck& at_most_named(const char* field, double x, const char* bound_name, double bound);
  /// Each component: "scale_sd[1]: must be > 0, is -1".
  template <int N, class Scalar>
  OptionsCheck& positive(const char* field, const Eigen::Matrix<Scalar, N, 1>& v) {
    for (int i = 0; i < N && !error_; ++i) component(field, i, v[i], true);
    return *this;
  }
  template <int N, class Scalar>
  OptionsCheck& non_negative(const char* field, const Eigen::Matrix<Scalar, N, 1>& v) {
    for (int i = 0; i < N && !error_; ++i) component(field, i, v[i], false);
    return *this;
  }
  /// A bound no comparison says: "must be BOUND, is VALUE" when !ok.
  OptionsCheck& require(bool ok, const char* field, const char* bound, double value);
  /// A condition between fields: "field: REASON" when !ok.
  OptionsCheck& require(bool ok, const char* field, const char* reason);
  /// A nested struct's verdict, its paths under `member`.
  OptionsCheck& nested(const char* member, const OptionCheck& check);

  bool failed() const { return error_.has_value(); }
  OptionCheck result() const { return error_; }

 private:
  /// Stores e + ", is VALUE".
  void refuse(InvalidOption e, double value);
  /// False (and refused unless an earlier check failed) when x is not finite.
  bool finite(const char* field, double x);
  /// Unless ok: "must be OP BOUND" or "must be OP BOUND_NAME (BOUND)".
  void compare(const char* field, double x, bool ok, const char* op, const char* bound_name,
               double bound);
  /// Unless ok: "must be in (lo, hi]" with the brackets given.
  void interval(const char* field, double x, bool ok, const char* open_bracket, double lo,
                double hi, const char* close_bracket);
  void component(const char* field, int i, double x, bool strict);
  OptionCheck error_;
};

}  // namespace moa
