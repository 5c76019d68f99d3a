#pragma once
// Typed, range-checked reading of one TOML section. Every error names the
// source (file or "--set"), the key as SECTION.KEY and what is allowed. The
// reader remembers the keys it was asked for, so finish() can refuse any
// other: the allowed keys are the ones read, declared once, where they are read.

#include <toml++/toml.h>

#include <initializer_list>
#include <limits>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "piezo/interval.hpp"
#include "piezo/name_table.hpp"

namespace piezo::config {

/// An allowed interval; open ends exclude the bound.
using Range = Interval;

inline constexpr double kInf = std::numeric_limits<double>::infinity();
inline constexpr Range kPositive{0.0, kInf, true, true};      ///< > 0
inline constexpr Range kNonNegative{0.0, kInf, false, true};  ///< >= 0

/// One key as its reader declares it, for the configuration reference
/// (docs/configuration.md is checked against these).
struct KeyDeclaration {
  std::string key;                   ///< "drive.sim.dac_bits"
  std::string kind;                  ///< number, integer, choice, flag, text, list
  std::string unit;                  ///< empty: none
  Range range;                       ///< numbers, integers and a list's items
  std::vector<std::string> choices;  ///< a choice's names
  std::string default_text;          ///< the value before any file: "20", "sim", "" (none)
  double default_value = std::numeric_limits<double>::quiet_NaN();  ///< numbers and integers
};
using KeyDeclarations = std::vector<KeyDeclaration>;

class SectionReader {
 public:
  /// A missing section reads as empty: every key keeps its value. A dotted
  /// name ("drive.sim") is a table inside a table.
  SectionReader(const toml::table& root, std::string section, std::string source);

  /// The table KEY inside this section ([SECTION.KEY]): a backend's own keys.
  [[nodiscard]] SectionReader subsection(const std::string& key);
  /// A key that has moved: refused, naming where it lives now
  /// ("drive.sim.dac_bits"; more than one when it was shared).
  void moved(const std::string& key, const std::vector<std::string>& now);

  [[nodiscard]] bool has(const std::string& key) const;

  void number(const std::string& key, double& value, const Range& allowed,
              const std::string& unit = "");
  void integer(const std::string& key, int& value, int min, int max);
  void choice(const std::string& key, std::string& value, const std::vector<std::string>& allowed);
  /// One of an enum's names (its table's, which the value's writers use too).
  template <class Enum, std::size_t N>
  void choice(const std::string& key, Enum& value, const NameTable<Enum, N>& names) {
    std::vector<std::string> allowed;
    for (const auto& [e, name] : names.entries()) allowed.emplace_back(name);
    std::string text(names.name(value));
    choice(key, text, allowed);
    if (const auto e = names.parse(text)) value = *e;
  }
  void flag(const std::string& key, bool& value);
  /// A non-empty array of integers, each in [min, max].
  void integer_list(const std::string& key, std::vector<int>& value, int min, int max);
  /// Any non-empty string.
  void text(const std::string& key, std::string& value);

  /// Throws for the first key of the section that no call above asked for.
  void finish() const;

  [[nodiscard]] std::string name(const std::string& key) const { return section_ + "." + key; }
  [[nodiscard]] const std::string& source() const { return source_; }

 private:
  void note(const std::string& key);

  SectionReader(const toml::table* table, std::string section, std::string source,
                KeyDeclarations* declarations)
      : table_(table),
        section_(std::move(section)),
        source_(std::move(source)),
        declarations_(declarations) {}
  void declare(KeyDeclaration d);

  const toml::table* table_ = nullptr;
  std::string section_;
  std::string source_;
  std::vector<std::string> read_;            ///< every key asked for, in order
  KeyDeclarations* declarations_ = nullptr;  ///< where keys are declared, when asked

  friend class TableReader;
};

/// The sections of one table (a file, or one --set): section() hands out a
/// reader per section and finish() refuses a section no one asked for.
/// With a `prefix` ("axes.phi"), the sections are the ones inside that
/// table of the root ([axes.phi.drive], ...), and every error names them so.
class TableReader {
 public:
  /// With `declarations`, every key read is declared there too.
  TableReader(const toml::table& root, std::string source, KeyDeclarations* declarations = nullptr,
              std::string prefix = "")
      : root_(root),
        source_(std::move(source)),
        declarations_(declarations),
        prefix_(std::move(prefix)) {}

  [[nodiscard]] SectionReader section(const std::string& name);
  void finish() const;

 private:
  const toml::table& root_;
  std::string source_;
  std::vector<std::string> read_;
  KeyDeclarations* declarations_ = nullptr;
  std::string prefix_;
};

}  // namespace piezo::config
