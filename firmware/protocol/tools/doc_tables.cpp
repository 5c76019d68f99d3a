// The docs' tables of the requests' arguments, written from their one
// declaration (request_arguments.hpp, move_request.hpp): between the
// markers
//   <!-- table: NAME (generated: cmake --build --preset ci --target doc-tables) -->
//   <!-- end of table -->
// in docs/protocol.md, docs/configuration.md and docs/positioning.md.
//   piezo_doc_tables SOURCE_DIR          rewrites the tables
//   piezo_doc_tables SOURCE_DIR --check  exits 1 naming each table that is stale
// A new argument or move option is its declaration; its rows follow.

#include <fmt/format.h>

#include <cstring>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <span>
#include <sstream>
#include <string>
#include <vector>

#include "piezo/firmware/move_request.hpp"
#include "piezo/protocol/messages.hpp"

namespace {

using piezo::firmware::Argument;
using piezo::firmware::MoveField;
namespace firmware = piezo::firmware;
namespace protocol = piezo::protocol;

constexpr const char* kRegenerate = "cmake --build --preset ci --target doc-tables";

std::string unit_cell(std::string_view unit) {
  return unit.empty() ? "–" : std::string(unit);
}

std::string arguments_table(std::span<const Argument> declared) {
  std::string out = "| argument | unit | allowed | default | meaning |\n|---|---|---|---|---|\n";
  for (const Argument& a : declared) {
    out += fmt::format("| `{}` | {} | {} | {} | {} |\n", a.name, unit_cell(a.unit),
                       firmware::allowed_text(a), a.default_text, a.doc);
  }
  return out;
}

/// A move's fields: as the protocol's arguments, the config's [move] keys
/// (no required field: it is no config key) or `piezo move`'s options.
enum class MoveTable { arguments, config_keys, options };

std::string move_table(MoveTable kind) {
  std::string out =
      kind == MoveTable::options ? "| option | key | unit | allowed | default | meaning |\n"
                                   "|---|---|---|---|---|---|\n"
      : kind == MoveTable::config_keys
          ? "| key | unit | allowed | default | meaning |\n|---|---|---|---|---|\n"
          : "| argument | unit | allowed | default | meaning |\n|---|---|---|---|---|\n";
  for (const MoveField& f : firmware::kMoveFields) {
    if (f.required && kind == MoveTable::config_keys) continue;
    if (kind == MoveTable::options) out += fmt::format("| `{}` ", f.option);
    out += fmt::format("| `{}` | {} | {} | {} | {} |\n", f.name, unit_cell(f.unit),
                       firmware::allowed_text(f),
                       f.required ? std::string("required") : firmware::default_text(f), f.doc);
  }
  return out;
}

/// Every table by its marker's name: a move's three, `move_to`'s waveform,
/// and each documented request's under its command.
const std::map<std::string, std::function<std::string()>>& tables() {
  static const std::map<std::string, std::function<std::string()>> all = [] {
    std::map<std::string, std::function<std::string()>> t{
        {"move_to", [] { return move_table(MoveTable::arguments); }},
        {"move-config", [] { return move_table(MoveTable::config_keys); }},
        {"move-options", [] { return move_table(MoveTable::options); }},
        {"move_to-waveform",
         [] { return arguments_table(protocol::MoveToRequest::kWaveformArgs); }},
    };
    std::apply(
        [&](auto... request) {
          ((t[std::string(decltype(request)::kCommand)] =
                [] {
                  static constexpr auto declared = protocol::arguments_of<decltype(request)>();
                  return arguments_table(declared);
                }),
           ...);
        },
        protocol::DocumentedRequests{});
    return t;
  }();
  return all;
}

/// The page with each marked table written anew; `stale` gets the names
/// of those that differed, `seen` every name found.
std::string regenerated(const std::string& page, const std::string& file,
                        std::vector<std::string>& stale, std::vector<std::string>& seen) {
  std::istringstream in(page);
  std::string out, line, name;
  bool inside = false;
  std::string old_rows;
  while (std::getline(in, line)) {
    if (!inside && line.rfind("<!-- table: ", 0) == 0) {
      name = line.substr(std::strlen("<!-- table: "));
      name = name.substr(0, name.find(' '));
      const auto it = tables().find(name);
      if (it == tables().end()) throw std::runtime_error(file + ": no table named " + name);
      seen.push_back(name);
      out += line + "\n";
      inside = true;
      old_rows.clear();
      continue;
    }
    if (inside && line == "<!-- end of table -->") {
      const std::string rows = tables().at(name)();
      if (rows != old_rows) stale.push_back(file + ": " + name);
      out += rows + line + "\n";
      inside = false;
      continue;
    }
    if (inside) {
      old_rows += line + "\n";
    } else {
      out += line + "\n";
    }
  }
  if (inside) throw std::runtime_error(file + ": table " + name + " has no end marker");
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || (argc == 3 && std::strcmp(argv[2], "--check") != 0) || argc > 3) {
    std::cerr << "usage: piezo_doc_tables SOURCE_DIR [--check]\n";
    return 2;
  }
  const std::string source = argv[1];
  const bool check = argc == 3;
  std::vector<std::string> stale, seen;
  try {
    for (const char* file : {"docs/protocol.md", "docs/configuration.md", "docs/positioning.md"}) {
      std::ifstream in(source + "/" + file);
      if (!in) throw std::runtime_error(source + "/" + file + ": cannot be read");
      const std::string page((std::istreambuf_iterator<char>(in)), {});
      const std::string now = regenerated(page, file, stale, seen);
      if (!check && now != page) std::ofstream(source + "/" + file) << now;
    }
  } catch (const std::exception& e) {
    std::cerr << "piezo_doc_tables: " << e.what() << "\n";
    return 2;
  }
  for (const auto& [name, make] : tables()) {
    if (std::find(seen.begin(), seen.end(), name) == seen.end()) {
      std::cerr << "piezo_doc_tables: table " << name << " is on no page\n";
      return 1;
    }
  }
  if (check && !stale.empty()) {
    for (const auto& s : stale) std::cerr << "stale table: " << s << "\n";
    std::cerr << "regenerate them with: " << kRegenerate << "\n";
    return 1;
  }
  if (!check) std::cout << "doc tables: " << seen.size() << " written\n";
  return 0;
}
