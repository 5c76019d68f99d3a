#include "section_reader.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "config_error.hpp"

namespace piezo::config {

SectionReader::SectionReader(const toml::table& root, std::string section, std::string source)
    : section_(std::move(section)), source_(std::move(source)) {
  if (const toml::node* node = root.get(section_)) {
    table_ = node->as_table();
    if (table_ == nullptr)
      throw ConfigError(source_, section_, "must be a table ([" + section_ + "])");
  }
}

void SectionReader::note(const std::string& key) {
  if (std::find(read_.begin(), read_.end(), key) == read_.end()) read_.push_back(key);
}

bool SectionReader::has(const std::string& key) const {
  return table_ != nullptr && table_->contains(key);
}

void SectionReader::number(const std::string& key, double& value, const Range& allowed,
                           const std::string& unit) {
  note(key);
  if (!has(key)) return;
  const toml::node& node = *table_->get(key);
  const auto v = node.value<double>();
  if (!v || !(node.is_floating_point() || node.is_integer())) {
    throw ConfigError(source_, name(key), "must be a number in " + allowed.text() + " " + unit);
  }
  if (!allowed.admits(*v)) {
    throw ConfigError(source_, name(key),
                      fmt::format("value {:g}{} is outside the allowed range {}{}", *v,
                                  unit.empty() ? "" : " " + unit, allowed.text(),
                                  unit.empty() ? "" : " " + unit));
  }
  value = *v;
}

void SectionReader::integer(const std::string& key, int& value, int min, int max) {
  note(key);
  if (!has(key)) return;
  const toml::node& node = *table_->get(key);
  const auto v = node.value<std::int64_t>();
  if (!node.is_integer() || !v || *v < min || *v > max) {
    throw ConfigError(source_, name(key), fmt::format("must be an integer in [{}, {}]", min, max));
  }
  value = static_cast<int>(*v);
}

void SectionReader::choice(const std::string& key, std::string& value,
                           const std::vector<std::string>& allowed) {
  note(key);
  if (!has(key)) return;
  const auto v = table_->get(key)->value<std::string>();
  if (!v || std::find(allowed.begin(), allowed.end(), *v) == allowed.end()) {
    throw ConfigError(source_, name(key),
                      fmt::format("must be one of: \"{}\"", fmt::join(allowed, "\", \"")));
  }
  value = *v;
}

void SectionReader::integer_list(const std::string& key, std::vector<int>& value, int min,
                                 int max) {
  note(key);
  if (!has(key)) return;
  const toml::array* array = table_->get(key)->as_array();
  const std::string allowed =
      fmt::format("must be a non-empty array of integers in [{}, {}]", min, max);
  if (array == nullptr || array->empty()) throw ConfigError(source_, name(key), allowed);
  std::vector<int> out;
  for (const toml::node& node : *array) {
    const auto v = node.value<std::int64_t>();
    if (!node.is_integer() || !v || *v < min || *v > max)
      throw ConfigError(source_, name(key), allowed);
    out.push_back(static_cast<int>(*v));
  }
  value = std::move(out);
}

void SectionReader::text(const std::string& key, std::string& value) {
  note(key);
  if (!has(key)) return;
  const auto v = table_->get(key)->value<std::string>();
  if (!v || v->empty()) throw ConfigError(source_, name(key), "must be a non-empty string");
  // A control character (a NUL above all) would cut or garble every message
  // and path made from the value.
  const auto bad = std::find_if(v->begin(), v->end(),
                                [](char c) { return static_cast<unsigned char>(c) < 0x20; });
  if (bad != v->end()) {
    throw ConfigError(
        source_, name(key),
        fmt::format("must not contain control characters (U+{:04X} at character {})",
                    static_cast<unsigned>(static_cast<unsigned char>(*bad)), bad - v->begin() + 1));
  }
  value = *v;
}

void SectionReader::flag(const std::string& key, bool& value) {
  note(key);
  if (!has(key)) return;
  const toml::node& node = *table_->get(key);
  if (!node.is_boolean()) throw ConfigError(source_, name(key), "must be true or false");
  value = *node.value<bool>();
}

void SectionReader::finish() const {
  if (table_ == nullptr) return;
  for (const auto& [k, node] : *table_) {
    const std::string key(k.str());
    if (std::find(read_.begin(), read_.end(), key) == read_.end()) {
      throw ConfigError(source_, name(key),
                        fmt::format("unknown key (allowed: {})", fmt::join(read_, ", ")));
    }
  }
}

SectionReader TableReader::section(const std::string& name) {
  if (std::find(read_.begin(), read_.end(), name) == read_.end()) read_.push_back(name);
  return {root_, name, source_};
}

void TableReader::finish() const {
  for (const auto& [k, node] : root_) {
    const std::string name(k.str());
    if (std::find(read_.begin(), read_.end(), name) == read_.end()) {
      throw ConfigError(source_, name,
                        fmt::format("unknown section (allowed: {})", fmt::join(read_, ", ")));
    }
  }
}

}  // namespace piezo::config
