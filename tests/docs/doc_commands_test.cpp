// The documentation's commands, run as written: every ```sh block of
// README.md and docs/*.md is executed line by line, in a scratch directory
// that holds the repository's configs/, with `piezo` meaning the binary
// built beside this test. A page's blocks run in order in one directory, so
// a later command can read what an earlier one wrote. Blocks fenced
// otherwise (indented, ```text, ```python) are illustrations and are not run.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <string>
#include <vector>

#include "../support/run_command.hpp"
#include "build_paths.hpp"

namespace {

namespace fs = std::filesystem;
using piezo::testing::fresh_temp_dir;
using piezo::testing::run_command;

const std::string kPiezo = build_paths::piezo;
const fs::path kSource = build_paths::source_dir;

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

/// The `piezo` command lines shown in a page's code (indented blocks and
/// fenced ones), continuation lines joined.
std::vector<std::string> piezo_lines(const fs::path& page) {
  std::ifstream in(page);
  std::vector<std::string> out;
  bool fenced = false;
  std::string pending;
  const std::regex command(R"((^|\s|/)piezo ([a-z][a-z-]*)( |$))");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("```", 0) == 0) {
      fenced = !fenced;
      continue;
    }
    const bool code = fenced || line.rfind("    ", 0) == 0;
    if (!pending.empty()) {
      pending += " " + line;
    } else if (code && std::regex_search(line, command)) {
      pending = line;
    }
    if (!pending.empty() && (pending.empty() || pending.back() != '\\')) {
      out.push_back(pending);
      pending.clear();
    }
  }
  return out;
}

// Commands shown as synopses or examples (not run: they take a board, a
// port or minutes) must still exist, with the options they show.
TEST(DocCommands, EveryPiezoCommandShownExistsWithTheOptionsItShows) {
  const std::regex command(R"((?:^|\s|/)piezo ([a-z][a-z-]*)(?: (read|list))?(?= |$))");
  const std::regex option(R"(--[a-z][a-z0-9-]*)");
  std::map<std::string, std::string> help;  // subcommand -> its --help
  std::size_t checked = 0;
  for (const auto& page : pages()) {
    for (const auto& line : piezo_lines(page)) {
      std::smatch m;
      if (!std::regex_search(line, m, command)) continue;
      const std::string sub = m[2].matched ? m[1].str() + " " + m[2].str() : m[1].str();
      if (!help.count(sub)) {
        const auto r = run_command(kPiezo + " " + sub + " --help");
        ASSERT_EQ(r.exit_code, 0) << page.filename().string() << ": `piezo " << sub
                                  << "` is not a command\n"
                                  << line << "\n"
                                  << r.err;
        help[sub] = r.out;
      }
      // The options after this command (another command on the line starts over).
      const std::string rest = m.suffix().str().substr(0, m.suffix().str().find("piezo "));
      for (std::sregex_iterator it(rest.begin(), rest.end(), option), end; it != end; ++it) {
        EXPECT_NE(help[sub].find(it->str()), std::string::npos)
            << page.filename().string() << ": `piezo " << sub << "` has no option " << it->str()
            << "\n"
            << line;
        ++checked;
      }
    }
  }
  EXPECT_GE(help.size(), 15u) << "most commands are shown somewhere";
  EXPECT_GE(checked, 50u);
}

}  // namespace
