// Names of enum values: one table per enum, each value once with its token
// ("consensus", "wheels"), read both ways. An enum's name() is that token;
// describe() is a sentence for the error enums.
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string_view>

namespace moa {

template <class E>
struct NameEntry {
  E value;
  const char* name;
};

/// The token of `value` in `table`; nullptr when the table lacks it (a value
/// cast from an out-of-range integer).
template <class E, std::size_t N>
constexpr const char* to_name(const std::array<NameEntry<E>, N>& table, E value) {
  for (const auto& entry : table) {
    if (entry.value == value) return entry.name;
  }
  return nullptr;
}

/// The value whose token is `name`; nullopt for any other name.
template <class E, std::size_t N>
constexpr std::optional<E> from_name(const std::array<NameEntry<E>, N>& table,
                                     std::string_view name) {
  for (const auto& entry : table) {
    if (name == entry.name) return entry.value;
  }
  return std::nullopt;
}

}  // namespace moa
