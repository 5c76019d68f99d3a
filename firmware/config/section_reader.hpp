#pragma once
// Typed, range-checked reading of one TOML section. Every error names the
// source (file or "--set"), the key as SECTION.KEY and what is allowed.

#include <toml++/toml.h>

#include <limits>
#include <string>
#include <vector>

namespace piezo::config {

/// An allowed interval; open ends exclude the bound.
struct Range {
  double min;
  double max;
  bool min_open = false;
  bool max_open = false;

  [[nodiscard]] bool admits(double v) const;
  [[nodiscard]] std::string text() const;
};

inline constexpr double kInf = std::numeric_limits<double>::infinity();

class SectionReader {
 public:
  /// A missing section reads as empty: every key keeps its value.
  SectionReader(const toml::table& root, std::string section, std::string source);

  [[nodiscard]] bool has(const std::string& key) const;

  void number(const std::string& key, double& value, const Range& allowed,
              const std::string& unit = "");
  void integer(const std::string& key, int& value, int min, int max);
  void choice(const std::string& key, std::string& value, const std::vector<std::string>& allowed);
  void flag(const std::string& key, bool& value);
  /// A non-empty array of integers, each in [min, max].
  void integer_list(const std::string& key, std::vector<int>& value, int min, int max);
  /// Any non-empty string.
  void text(const std::string& key, std::string& value);

  /// Throws for the first key not in `known` (keys read elsewhere included).
  void reject_unknown(const std::vector<std::string>& known) const;

  [[nodiscard]] std::string name(const std::string& key) const { return section_ + "." + key; }
  [[nodiscard]] const std::string& source() const { return source_; }

 private:
  const toml::table* table_ = nullptr;
  std::string section_;
  std::string source_;
};

}  // namespace piezo::config

// The host reads rig configs through the same names.
namespace piezo::host {
using namespace piezo::config;  // NOLINT(google-build-using-namespace)
}  // namespace piezo::host
