// docs/configuration.md against the config readers: the keys a reader
// accepts are the ones it lists when it refuses an unknown key (the readers
// declare each key once, where they read it), so asking `piezo` about a
// made-up key in every section gives the whole accepted set. Each must be
// documented in its section's table, and the page may document nothing
// the readers refuse.

#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>

#include "../support/run_command.hpp"

namespace {

using piezo::testing::run_command;

const std::string kPiezo = PIEZO_BINARY;
const std::string kSource = PIEZO_SOURCE_DIR;

/// The comma-separated names inside "(allowed: ...)" of a refusal.
std::set<std::string> allowed_in(const std::string& error) {
  const auto open = error.find("(allowed: ");
  if (open == std::string::npos) return {};
  const auto close = error.find(')', open);
  std::stringstream names(error.substr(open + 10, close - open - 10));
  std::set<std::string> out;
  for (std::string name; std::getline(names, name, ',');) {
    name.erase(0, name.find_first_not_of(' '));
    out.insert(name);
  }
  return out;
}

std::set<std::string> refused_with(const std::string& setting) {
  const auto r =
      run_command(kPiezo + " run --config " + kSource +
                  "/configs/sim.toml --duration 0.01 --out /nonexistent/x --set " + setting);
  EXPECT_EQ(r.exit_code, 2) << r.err;
  return allowed_in(r.err);
}

/// Section name -> keys accepted by the readers.
std::map<std::string, std::set<std::string>> accepted_keys() {
  std::map<std::string, std::set<std::string>> keys;
  for (const auto& section : refused_with("no_such_section.key=1")) {
    keys[section] = refused_with(section + ".no_such_key=1");
  }
  return keys;
}

/// Section name -> keys documented: the backticked names in the first cell
/// of each table row under "## `[section]`".
std::map<std::string, std::set<std::string>> documented_keys() {
  std::ifstream page(kSource + "/docs/configuration.md");
  EXPECT_TRUE(page) << "docs/configuration.md is missing";
  const std::regex heading(R"(^## `\[([a-z_]+)\]`)");
  const std::regex name("`([A-Za-z0-9_]+)`");
  std::map<std::string, std::set<std::string>> keys;
  std::string section;
  for (std::string line; std::getline(page, line);) {
    std::smatch m;
    if (std::regex_search(line, m, heading)) {
      section = m[1];
      keys[section];
      continue;
    }
    if (line.rfind("## ", 0) == 0) section.clear();
    if (section.empty() || line.rfind("| `", 0) != 0) continue;
    const std::string cell = line.substr(1, line.find('|', 1) - 1);
    for (std::sregex_iterator it(cell.begin(), cell.end(), name), end; it != end; ++it) {
      keys[section].insert((*it)[1]);
    }
  }
  return keys;
}

TEST(ConfigReference, EveryAcceptedKeyIsDocumentedAndNothingElse) {
  const auto accepted = accepted_keys();
  const auto documented = documented_keys();
  ASSERT_GE(accepted.size(), 10u) << "could not read the sections from piezo's refusals";
  for (const auto& [section, keys] : accepted) {
    ASSERT_FALSE(keys.empty()) << "[" << section << "]: no keys read from piezo's refusal";
    const auto page = documented.find(section);
    ASSERT_NE(page, documented.end()) << "[" << section << "] has no section in the reference";
    for (const auto& key : keys) {
      EXPECT_TRUE(page->second.count(key) == 1)
          << section << "." << key << " is accepted but not documented";
    }
    for (const auto& key : page->second) {
      EXPECT_TRUE(keys.count(key) == 1)
          << section << "." << key << " is documented but no reader accepts it";
    }
  }
  for (const auto& [section, keys] : documented) {
    EXPECT_TRUE(accepted.count(section) == 1)
        << "[" << section << "] is documented but no reader accepts it";
  }
}

}  // namespace
