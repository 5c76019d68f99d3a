#pragma once
/// @file
/// One table per enum that gives both directions, name and value: the
/// config readers, the wire, the logs and the messages all say an enum's
/// value by the name its table holds, and read it back through the same
/// table. Header-only and constexpr; the bottom of the tree, so that every
/// layer may use it.

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

namespace piezo {

template <class Enum, std::size_t N>
class NameTable {
 public:
  using Entry = std::pair<Enum, std::string_view>;

  constexpr explicit NameTable(std::array<Entry, N> entries) : entries_(entries) {}

  /// The value's name; "unknown" for a value the table does not hold (a
  /// code read from a damaged file, say).
  [[nodiscard]] constexpr std::string_view name(Enum value) const {
    for (const auto& [e, n] : entries_) {
      if (e == value) return n;
    }
    return "unknown";
  }
  /// The value a name stands for, if any.
  [[nodiscard]] constexpr std::optional<Enum> parse(std::string_view text) const {
    for (const auto& [e, n] : entries_) {
      if (n == text) return e;
    }
    return std::nullopt;
  }
  /// Every name, in the table's order, separated by `separator` (for the
  /// "allowed: ..." of an error).
  [[nodiscard]] std::string list(std::string_view separator = ", ") const {
    std::string out;
    for (const auto& [e, n] : entries_) {
      if (!out.empty()) out += separator;
      out += n;
    }
    return out;
  }
  [[nodiscard]] constexpr const std::array<Entry, N>& entries() const { return entries_; }

 private:
  std::array<Entry, N> entries_;
};

/// A table from {value, "name"} pairs: `names<Color>({{Color::red, "red"}, ...})`.
template <class Enum, std::size_t N>
constexpr NameTable<Enum, N> names(const std::pair<Enum, std::string_view> (&entries)[N]) {
  std::array<std::pair<Enum, std::string_view>, N> a{};
  for (std::size_t i = 0; i < N; ++i) a[i] = entries[i];
  return NameTable<Enum, N>(a);
}

}  // namespace piezo
