#include "piezo/config/section_reader.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "piezo/config/config_error.hpp"

namespace piezo::config {

namespace {

/// The table `name` inside `parent` (null when absent); anything else there is refused.
const toml::table* table_in(const toml::table* parent, const std::string& key,
                            const std::string& name, const std::string& source) {
  const toml::node* node = parent == nullptr ? nullptr : parent->get(key);
  if (node == nullptr) return nullptr;
  if (node->as_table() == nullptr)
    throw ConfigError(source, name, "must be a table ([" + name + "])");
  return node->as_table();
}

}  // namespace

SectionReader::SectionReader(const toml::table& root, std::string section, std::string source)
    : section_(std::move(section)), source_(std::move(source)) {
  table_ = &root;
  std::string::size_type begin = 0;
  for (;;) {
    const auto dot = section_.find('.', begin);
    table_ =
        table_in(table_, section_.substr(begin, dot - begin), section_.substr(0, dot), source_);
    if (dot == std::string::npos) break;
    begin = dot + 1;
  }
}

SectionReader SectionReader::subsection(const std::string& key) {
  note(key);
  return {table_in(table_, key, name(key), source_), name(key), source_, declarations_};
}

void SectionReader::declare(KeyDeclaration d) {
  if (declarations_ == nullptr) return;
  for (const KeyDeclaration& known : *declarations_)
    if (known.key == d.key) return;  // two backends on one section read it twice
  declarations_->push_back(std::move(d));
}

void SectionReader::moved(const std::string& key, const std::vector<std::string>& now) {
  if (!has(key)) return;
  std::vector<std::string> places;
  for (const std::string& name : now) {
    const auto dot = name.rfind('.');
    places.push_back(
        fmt::format("{} (key `{}` in [{}])", name, name.substr(dot + 1), name.substr(0, dot)));
  }
  throw ConfigError(source_, name(key),
                    fmt::format("has moved: it is now {}", fmt::join(places, " or ")));
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
  declare({name(key),
           "number",
           unit,
           allowed,
           {},
           std::isfinite(value) ? fmt::format("{:g}", value) : "",
           value});
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
  declare({name(key),
           "integer",
           "",
           {double(min), double(max)},
           {},
           std::to_string(value),
           double(value)});
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
  declare({name(key), "choice", "", {}, allowed, value});
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
  std::vector<std::string> items;
  for (const int v : value) items.push_back(std::to_string(v));
  declare({name(key),
           "list",
           "",
           {double(min), double(max)},
           {},
           fmt::format("{}", fmt::join(items, ", "))});
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
  declare({name(key), "text", "", {}, {}, value});
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
  declare({name(key), "flag", "", {}, {}, value ? "true" : "false"});
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
  SectionReader reader(root_, prefix_.empty() ? name : prefix_ + "." + name, source_);
  reader.declarations_ = declarations_;
  return reader;
}

void TableReader::finish() const {
  const toml::table* table = &root_;
  if (!prefix_.empty()) {
    // The prefix's table, if the root has it (SectionReader checks each level).
    const SectionReader at_prefix(root_, prefix_, source_);
    table = at_prefix.table_;
    if (table == nullptr) return;
  }
  for (const auto& [k, node] : *table) {
    const std::string name(k.str());
    if (std::find(read_.begin(), read_.end(), name) == read_.end()) {
      const std::string shown = prefix_.empty() ? name : prefix_ + "." + name;
      throw ConfigError(source_, shown,
                        fmt::format("unknown section (allowed: {})", fmt::join(read_, ", ")));
    }
  }
}

}  // namespace piezo::config
