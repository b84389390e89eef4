// Names of enum values: one table per enum, each value once with its token
// ("consensus", "wheels"), read both ways. An enum with a table specialises
// EnumNames next to its declaration:
//   template <> struct EnumNames<Source> {
//     static constexpr std::array<NameEntry<Source>, 3> kTable{{...}};
//   };
// Tokens are what files and flags carry (to_name, from_name); a sentence
// for the user is describe(), kept for the error enums.
#pragma once

#include <array>
#include <optional>
#include <string_view>

namespace moa {

template <class E>
struct NameEntry {
  E value;
  const char* name;
};

/// Specialised per enum with `static constexpr std::array<NameEntry<E>, N> kTable`.
template <class E>
struct EnumNames;

template <class E>
concept NamedEnum = requires {
  EnumNames<E>::kTable;
};

/// The token of `value`; "?" for a value not in the table (cast from an
/// out-of-range integer).
template <NamedEnum E>
constexpr const char* to_name(E value) {
  for (const auto& entry : EnumNames<E>::kTable) {
    if (entry.value == value) return entry.name;
  }
  return "?";
}

/// `value` is in the table.
template <NamedEnum E>
constexpr bool is_named(E value) {
  for (const auto& entry : EnumNames<E>::kTable) {
    if (entry.value == value) return true;
  }
  return false;
}

/// The value whose token is `name`; nullopt for any other name.
template <NamedEnum E>
constexpr std::optional<E> from_name(std::string_view name) {
  for (const auto& entry : EnumNames<E>::kTable) {
    if (name == entry.name) return entry.value;
  }
  return std::nullopt;
}

}  // namespace moa
