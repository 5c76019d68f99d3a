// The documentation's commands, run as written: every ```sh block of
// README.md and docs/*.md is executed line by line, in a scratch directory
// that holds the repository's configs/, with `piezo` meaning the binary
// built beside this test. A page's blocks run in order in one directory, so
// a later command can read what an earlier one wrote. Blocks fenced
// otherwise (indented, ```text, ```python) are illustrations and are not run.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "../support/run_command.hpp"

namespace {

namespace fs = std::filesystem;
using piezo::testing::fresh_temp_dir;
using piezo::testing::run_command;

const std::string kPiezo = PIEZO_BINARY;
const fs::path kSource = PIEZO_SOURCE_DIR;

/// The command lines of the page's ```sh blocks (comments and blank lines
/// left out).
std::vector<std::string> shell_lines(const fs::path& page) {
  std::ifstream in(page);
  std::vector<std::string> lines;
  bool in_block = false;
  for (std::string line; std::getline(in, line);) {
    if (!in_block && line == "```sh") {
      in_block = true;
    } else if (in_block && line.rfind("```", 0) == 0) {
      in_block = false;
    } else if (in_block && !line.empty() && line[0] != '#') {
      lines.push_back(line);
    }
  }
  return lines;
}

std::vector<fs::path> pages() {
  std::vector<fs::path> out{kSource / "README.md"};
  for (const auto& entry : fs::directory_iterator(kSource / "docs")) {
    if (entry.path().extension() == ".md") out.push_back(entry.path());
  }
  return out;
}

TEST(DocCommands, EveryShellBlockInTheDocsRunsAsWritten) {
  std::size_t ran = 0;
  for (const auto& page : pages()) {
    const auto lines = shell_lines(page);
    if (lines.empty()) continue;
    const fs::path dir = fresh_temp_dir("doc-commands");
    fs::create_directory_symlink(kSource / "configs", dir / "configs");
    for (const auto& line : lines) {
      const std::string command = line.rfind("piezo ", 0) == 0 ? kPiezo + line.substr(5) : line;
      const auto r = run_command("cd '" + dir.string() + "' && " + command);
      EXPECT_EQ(r.exit_code, 0) << page.filename().string() << ": " << line << "\n" << r.err;
      ++ran;
    }
  }
  EXPECT_GE(ran, 7u) << "the getting-started page's session should be among them";
}

}  // namespace
