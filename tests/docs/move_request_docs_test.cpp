// The three pages that list a move's request, against its one declaration
// (firmware::kMoveFields): the protocol's `move_to` arguments, the config's
// [move] keys and `piezo move`'s options. Each row's unit, allowed values,
// default and meaning must be the declaration's, and every field must have
// its row; a failure prints the rows the page should hold.

#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <vector>

#include "build_paths.hpp"
#include "piezo/firmware/move_request.hpp"

namespace {

using piezo::firmware::kMoveFields;
using piezo::firmware::MoveField;

/// The table rows ("| `...") that follow the line `heading` on the page.
std::vector<std::string> table_after(const std::string& page, const std::string& heading) {
  std::ifstream in(std::string(build_paths::source_dir) + "/" + page);
  EXPECT_TRUE(in) << page;
  std::vector<std::string> rows;
  bool found = false;
  for (std::string line; std::getline(in, line);) {
    if (!found) {
      found = line == heading;
      continue;
    }
    if (line.rfind("| `", 0) == 0) {
      rows.push_back(line);
    } else if (!rows.empty()) {
      break;
    }
  }
  EXPECT_TRUE(found) << page << " has no line \"" << heading << "\"";
  return rows;
}

std::string row(const MoveField& f, bool with_option) {
  std::string r = "| ";
  if (with_option) r += "`" + std::string(f.option) + "` | ";
  r += "`" + std::string(f.name) + "` | " + (f.unit.empty() ? "–" : std::string(f.unit)) + " | " +
       piezo::firmware::allowed_text(f) + " | " +
       (f.required ? "required" : piezo::firmware::default_text(f)) + " | " + std::string(f.doc) +
       " |";
  return r;
}

void expect_rows(const std::string& page, const std::string& heading, bool with_option,
                 bool with_required) {
  const auto rows = table_after(page, heading);
  std::string expected;
  std::size_t count = 0;
  for (const MoveField& f : kMoveFields) {
    if (f.required && !with_required) continue;
    expected += row(f, with_option) + "\n";
    ++count;
  }
  bool all = rows.size() == count;
  for (const MoveField& f : kMoveFields) {
    if (f.required && !with_required) continue;
    const std::string want = row(f, with_option);
    bool seen = false;
    for (const auto& r : rows) seen = seen || r == want;
    all = all && seen;
    EXPECT_TRUE(seen) << page << ": no row " << want;
  }
  EXPECT_TRUE(all) << page << ", under \"" << heading << "\", should hold:\n" << expected;
}

TEST(MoveRequestDocs, TheProtocolsArgumentsAreTheDeclaration) {
  expect_rows("docs/protocol.md", "### `move_to`'s arguments", false, true);
}

TEST(MoveRequestDocs, TheConfigsMoveKeysAreTheDeclaration) {
  expect_rows("docs/configuration.md", "## `[move]`", false, false);
}

TEST(MoveRequestDocs, PiezoMovesOptionsAreTheDeclaration) {
  expect_rows("docs/positioning.md", "### A move's options", true, true);
}

}  // namespace
