#include "effective_config.hpp"

#include <toml++/toml.h>

#include <cmath>
#include <cstdint>
#include <sstream>
#include <string_view>

namespace piezo::config {

namespace {

/// The table at `path` ("axes.phi.drive"), made as needed.
toml::table& table_at(toml::table& root, std::string_view path) {
  toml::table* t = &root;
  while (!path.empty()) {
    const std::size_t dot = path.find('.');
    const std::string part(path.substr(0, dot));
    if (!t->contains(part)) t->insert(part, toml::table{});
    t = t->get(part)->as_table();
    path = dot == std::string_view::npos ? std::string_view() : path.substr(dot + 1);
  }
  return *t;
}

/// A declared key's value in its kind; an unset one (no end, no file) is left out.
void put(toml::table& t, const std::string& key, const KeyDeclaration& d) {
  if (d.kind == "number") {
    if (!std::isfinite(d.default_value)) return;
    t.insert_or_assign(key, d.default_value);
  } else if (d.kind == "integer") {
    t.insert_or_assign(key, static_cast<std::int64_t>(d.default_value));
  } else if (d.kind == "flag") {
    t.insert_or_assign(key, d.default_text == "true");
  } else if (d.kind == "list") {
    toml::array items;
    std::istringstream in(d.default_text);
    for (std::string item; std::getline(in, item, ',');) items.push_back(std::stoll(item));
    t.insert_or_assign(key, std::move(items));
  } else {  // choice, text
    if (d.default_text.empty()) return;
    t.insert_or_assign(key, d.default_text);
  }
}

}  // namespace

std::string effective_config_toml(const ConfigFile& file) {
  // Written from the readers' own declarations (effective_keys): every key
  // they read, every axis, never a copy of their keys kept here.
  toml::table out;
  for (const KeyDeclaration& d : effective_keys(file)) {
    const std::size_t dot = d.key.rfind('.');
    put(table_at(out, std::string_view(d.key).substr(0, dot)), d.key.substr(dot + 1), d);
  }
  // The axes in the board's order (a reader takes them in the file's order;
  // a TOML table's keys print sorted).
  toml::table axes;
  if (toml::table* own = out["axes"].as_table()) axes = std::move(*own);
  out.erase("axes");
  std::ostringstream text;
  text << out << "\n";
  for (const AxisConfig& a : file.board.axes) {
    if (toml::table* one = axes[a.name].as_table()) {
      text << "\n" << toml::table{{"axes", toml::table{{a.name, std::move(*one)}}}} << "\n";
    }
  }
  return text.str();
}

std::string run_config_file(const ConfigFile& c) {
  const std::string effective = effective_config_toml(c);
  if (c.text.empty()) {
    return "# What the run used, defaults included (it had no config file of its own).\n" +
           effective;
  }
  std::string out = c.text;
  if (!out.empty() && out.back() != '\n') out += '\n';
  out += "\n# What the run used, defaults included:\n";
  std::istringstream lines(effective);
  for (std::string line; std::getline(lines, line);) out += "#   " + line + "\n";
  return out;
}

}  // namespace piezo::config
