// docs/protocol.md's argument tables against the requests' declarations
// (each request's kArgs, from firmware/request_arguments.hpp): under
// "#### `cmd`" a row per argument with its unit, what it allows, its
// default and its meaning, and nothing else. A failure prints the table
// the page should hold.

#include <gtest/gtest.h>

#include <fstream>
#include <span>
#include <string>
#include <vector>

#include "build_paths.hpp"
#include "piezo/protocol/messages.hpp"

namespace {

using piezo::firmware::Argument;
namespace protocol = piezo::protocol;

/// The table rows ("| `...") under the line `heading`, up to the next heading.
std::vector<std::string> rows_under(const std::string& heading) {
  std::ifstream in(std::string(build_paths::source_dir) + "/docs/protocol.md");
  EXPECT_TRUE(in) << "docs/protocol.md is missing";
  std::vector<std::string> rows;
  bool found = false;
  for (std::string line; std::getline(in, line);) {
    if (!found) {
      found = line == heading;
      continue;
    }
    if (line.rfind("#", 0) == 0) break;
    if (line.rfind("| `", 0) == 0) rows.push_back(line);
  }
  EXPECT_TRUE(found) << "docs/protocol.md has no line \"" << heading << "\"";
  return rows;
}

std::string row(const Argument& a) {
  return "| `" + std::string(a.name) + "` | " + (a.unit.empty() ? "–" : std::string(a.unit)) +
         " | " + piezo::firmware::allowed_text(a) + " | " + std::string(a.default_text) + " | " +
         std::string(a.doc) + " |";
}

void expect_table(const std::string& heading, std::span<const Argument> declared) {
  std::vector<std::string> want;
  std::string text;
  for (const Argument& a : declared) {
    want.push_back(row(a));
    text += want.back() + "\n";
  }
  EXPECT_EQ(rows_under(heading), want)
      << "docs/protocol.md, under \"" << heading << "\", should hold:\n"
      << text;
}

TEST(RequestArgumentsDocs, EachCommandsTableIsItsDeclaration) {
  expect_table("#### `configure`", protocol::ConfigureRequest::kArgs);
  expect_table("#### `start`", protocol::StartRequest::kArgs);
  expect_table("#### `step`", protocol::StepRequest::kArgs);
  expect_table("#### `move_to`, besides the move's request",
               protocol::MoveToRequest::kWaveformArgs);
  expect_table("#### `calibrate`", protocol::CalibrateRequest::kArgs);
  expect_table("#### `lease`", protocol::LeaseRequest::kArgs);
  expect_table("#### `fetch`", protocol::FetchRequest::kArgs);
}

}  // namespace
