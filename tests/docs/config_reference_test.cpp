// docs/configuration.md against the config readers' own declarations
// (config::declared_keys(): each key declared where it is read, with its
// unit, range or choices and default). Every accepted key has its row under
// its section's heading, the page documents nothing the readers refuse, and
// each row's unit, allowed values and default are the declaration's. A
// failure prints what the row should say.

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <optional>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <filesystem>
#include <toml++/toml.h>

#include "build_paths.hpp"
#include "config/config_file.hpp"

namespace {

using piezo::config::KeyDeclaration;

struct Row {
  std::string unit, allowed, default_text;
};

std::string trim(std::string s) {
  s.erase(0, s.find_first_not_of(' '));
  s.erase(s.find_last_not_of(' ') + 1);
  return s;
}

/// The page's numbers as C reads them: "−" is a minus, "1e5" a number.
std::string plain(std::string s) {
  for (std::string::size_type at; (at = s.find("\u2212")) != std::string::npos;)
    s.replace(at, 3, "-");
  return s;
}

/// The names a cell lists in backticks (or, with none, separated by commas).
std::set<std::string> names_in(const std::string& cell) {
  std::set<std::string> out;
  const std::regex name("`([^`]+)`");
  for (std::sregex_iterator it(cell.begin(), cell.end(), name), end; it != end; ++it)
    out.insert((*it)[1]);
  if (out.empty()) {
    std::stringstream in(cell);
    for (std::string item; std::getline(in, item, ',');) out.insert(trim(item));
  }
  return out;
}

/// "section.key" -> its row's cells, from every "## `[section]`" table.
std::map<std::string, Row> documented_rows() {
  std::ifstream page(std::string(build_paths::source_dir) + "/docs/configuration.md");
  EXPECT_TRUE(page) << "docs/configuration.md is missing";
  const std::regex heading(R"(^## `\[([a-z_.\-]+)\]`)");
  std::map<std::string, Row> rows;
  std::string section;
  for (std::string line; std::getline(page, line);) {
    std::smatch m;
    if (std::regex_search(line, m, heading)) {
      section = m[1];
      continue;
    }
    if (line.rfind("## ", 0) == 0) section.clear();
    if (section.empty() || line.rfind("| `", 0) != 0) continue;
    std::vector<std::string> cells;
    std::stringstream in(line.substr(1));
    for (std::string cell; std::getline(in, cell, '|');) cells.push_back(trim(cell));
    if (cells.size() < 5) continue;
    // One row may document several keys; "as `[model]`" takes that section's row.
    for (const std::string& key : names_in(cells[0])) {
      Row row{cells[1], cells[2], cells[3]};
      std::smatch as;
      const std::regex as_section(R"(^as `\[([a-z_.\-]+)\]`)");
      if (std::regex_search(row.unit, as, as_section)) {
        const auto same_key = rows.find(std::string(as[1]) + "." + key);
        if (same_key != rows.end())
          row = {same_key->second.unit, same_key->second.allowed, cells[3]};
      }
      rows[section + "." + key] = row;
    }
  }
  return rows;
}

/// The interval a cell starts with: "[a, b]", "(a, b)", "> a", "≥ a".
std::optional<piezo::Interval> interval_in(const std::string& text) {
  const std::string cell = plain(text);
  std::smatch m;
  const std::regex both(R"(^([\[(])\s*([-+0-9.eE]+|-?inf),\s*([-+0-9.eE]+|inf)\s*([\])]))");
  if (std::regex_search(cell, m, both)) {
    return piezo::Interval{std::stod(m[2]), std::stod(m[3]), m[1] == "(", m[4] == ")"};
  }
  const std::regex dots(R"(^([-+0-9.eE]+)\.\.([-+0-9.eE]+))");  // [move]'s "1..16"
  if (std::regex_search(cell, m, dots)) return piezo::Interval{std::stod(m[1]), std::stod(m[2])};
  const std::regex above(R"(^(>|≥)\s*([-+0-9.eE]+))");
  if (std::regex_search(cell, m, above)) {
    return piezo::Interval{std::stod(m[2]), INFINITY, m[1] == ">", true};
  }
  return std::nullopt;
}

bool same(double a, double b) {
  return a == b || std::abs(a - b) <= 1e-12 * std::max(std::abs(a), std::abs(b));
}

bool same(const piezo::Interval& a, const piezo::Interval& b) {
  return same(a.min, b.min) && same(a.max, b.max) && a.min_open == b.min_open &&
         (a.max_open == b.max_open || std::isinf(a.max));
}

/// A default cell that says there is none (or that another section's applies).
bool says_none(const std::string& cell) {
  return cell == "none" || cell == "\u2013" || cell.rfind("none ", 0) == 0 ||
         cell.rfind("`[", 0) == 0;
}

/// A unit as the page prints it: "–" for none, "m²" for "m^2".
std::string printed_unit(std::string unit) {
  if (unit.empty() || unit == "-") return "\u2013";
  if (const auto at = unit.find("^2"); at != std::string::npos) unit.replace(at, 2, "\u00b2");
  return unit;
}

/// What is wrong with the row, or "".
std::string mismatch(const KeyDeclaration& d, const Row& row) {
  std::ostringstream why;
  const bool numeric = d.kind == "number" || d.kind == "integer";
  if (d.kind == "number" && row.unit != printed_unit(d.unit)) {
    why << "unit is \"" << row.unit << "\", declared \"" << printed_unit(d.unit) << "\"; ";
  }
  if (numeric || d.kind == "list") {
    const std::string cell = d.kind == "list" && row.allowed.rfind("list of ", 0) == 0
                                 ? row.allowed.substr(8)
                                 : row.allowed;
    const auto documented = interval_in(cell);
    if (!documented || !same(*documented, d.range)) {
      why << "allowed is \"" << row.allowed << "\", declared " << d.range.text() << "; ";
    }
  }
  if (d.kind == "choice") {
    const std::set<std::string> declared(d.choices.begin(), d.choices.end());
    if (names_in(row.allowed) != declared) {
      why << "allowed is \"" << row.allowed << "\", declared the choices of " << d.key << "; ";
    }
  }
  if (d.kind == "flag" && row.allowed != "true/false") why << "allowed must be true/false; ";
  // The default: a number where the declaration has one, "none" where it has none.
  // A default outside the range (an offset of -1 where [0, 1023] is
  // allowed) is none: the key is required where its backend is chosen.
  if (numeric && std::isfinite(d.default_value) && d.range.admits(d.default_value)) {
    const std::string cell = plain(row.default_text);
    char* end = nullptr;
    const double documented = std::strtod(cell.c_str(), &end);
    if (end == cell.c_str() || !same(documented, d.default_value)) {
      why << "default is \"" << row.default_text << "\", declared " << d.default_text << "; ";
    }
  } else if (numeric || d.default_text.empty()) {
    if (!says_none(row.default_text))
      why << "default is \"" << row.default_text << "\", declared none; ";
  } else if (d.kind != "list" && row.default_text != d.default_text &&
             row.default_text != "`" + d.default_text + "`") {
    why << "default is \"" << row.default_text << "\", declared " << d.default_text << "; ";
  }
  return why.str();
}

TEST(ConfigReference, EveryKeyHasItsRowWithTheDeclaredUnitRangeAndDefault) {
  const auto declared = piezo::config::declared_keys();
  auto rows = documented_rows();
  ASSERT_GE(declared.size(), 100u);
  for (const KeyDeclaration& d : declared) {
    const auto row = rows.find(d.key);
    if (row == rows.end()) {
      ADD_FAILURE() << d.key << " is accepted but has no row under its section's heading";
      continue;
    }
    const std::string why = mismatch(d, row->second);
    EXPECT_EQ(why, "") << d.key;
    rows.erase(row);
  }
  for (const auto& [key, row] : rows) {
    ADD_FAILURE() << key << " is documented but no reader accepts it";
  }
}

// The shipped configs' table names every file in configs/, and its clock
// column says what each file's [run] clock is: "virtual", "real time" (the
// default, for a rig), or "–" for a file with no rig (the model alone).
TEST(ConfigReference, TheShippedConfigsTableSaysEachFilesClock) {
  const std::string source = build_paths::source_dir;
  std::ifstream in(source + "/docs/configuration.md");
  std::stringstream page;
  page << in.rdbuf();
  const std::string text = page.str();
  const auto from = text.find("Configs shipped in `configs/`:");
  ASSERT_NE(from, std::string::npos);
  const std::string table = text.substr(from, text.find("\n\n", text.find("|---", from)) - from);
  std::map<std::string, std::string> documented;
  const std::regex row(R"(\| `([a-z0-9-]+\.toml)` \|[^\n]*\| ([^|\n]+) \|)");
  for (auto it = std::sregex_iterator(table.begin(), table.end(), row);
       it != std::sregex_iterator(); ++it) {
    documented[(*it)[1]] = trim((*it)[2]);
  }
  std::set<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(source + "/configs")) {
    if (entry.path().extension() != ".toml") continue;
    const std::string name = entry.path().filename().string();
    files.insert(name);
    const toml::table config = toml::parse_file(entry.path().string());
    const auto clock = config["run"]["clock"].value<std::string>();
    const bool rig = config.contains("sensor");
    const std::string expected = clock == "virtual" ? "virtual" : rig ? "real time" : "–";
    ASSERT_TRUE(documented.count(name)) << name << " has no row in the shipped configs' table";
    EXPECT_EQ(documented[name].substr(0, expected.size()), expected) << name;
  }
  for (const auto& [name, clock] : documented) {
    EXPECT_TRUE(files.count(name)) << name << " is in the table but not in configs/";
  }
}

}  // namespace
