// The `piezo` command line: one binary for the rig and the analyses. The
// model's commands are linked in; the rig's come from a module loaded when
// the command line asks for anything else, so that `piezo simulate` does
// not start ZeroMQ, Kerberos and the hardware libraries it never uses.

#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

#include "commands.hpp"
#include "exit_codes.hpp"
#include "io/module_loader.hpp"
#include "piezo/config/config_error.hpp"
#include "piezo/protocol/error.hpp"
#include "run/link_timeout.hpp"

namespace {
using piezo::host::kExitBadInput;
using piezo::host::kExitFailed;

/// Whether the command that was parsed (the innermost subcommand) was
/// given --json: a script then reads one JSON object on stdout, whatever
/// happens.
bool json_asked(const CLI::App& app) {
  for (const CLI::App* sub : app.get_subcommands()) {
    if (json_asked(*sub)) return true;
    const CLI::Option* json = sub->get_option_no_throw("--json");
    if (json != nullptr && json->count() > 0) return true;
  }
  return false;
}

/// The error on stderr, and with --json as one object on stdout: the
/// status, the error, its code (the protocol's error code for a board's
/// refusal, bad_input for bad input, no_reply for a silent board) and the
/// key at fault.
int report_error(bool json, int exit_code, const std::string& code, const std::string& key,
                 const std::string& message) {
  fmt::print(stderr, "piezo: error: {}\n", message);
  if (json) {
    fmt::print("{}\n", nlohmann::json{{"status", "failed"},
                                      {"error", message},
                                      {"code", code},
                                      {"key", key.empty() ? nlohmann::json() : nlohmann::json(key)},
                                      {"exit_code", exit_code}}
                           .dump());
  }
  return exit_code;
}

constexpr piezo::host::NamedCommand kModelCommands[] = {
    {"simulate", piezo::host::add_simulate_command},
    {"sensitivity", piezo::host::add_sensitivity_command},
    {"sweep", piezo::host::add_sweep_command},
    {"report", piezo::host::add_report_command},
    {"recover", piezo::host::add_recover_command},
    {"identify", piezo::host::add_identify_command},
    {"compare", piezo::host::add_compare_command},
};

/// The command line's first word that is not an option ("" when none):
/// the command it names, if any.
std::string_view first_word(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    if (argv[i][0] != '-') return argv[i];
  }
  return {};
}

/// The rig's commands (rig_commands.cpp) from their module: the one
/// `named` names, or all of them.
void add_rig_commands(CLI::App& app, piezo::host::Commands& commands, std::string_view named) {
  using Entry = void (*)(CLI::App&, piezo::host::Commands&, const char*);
  const auto entry = reinterpret_cast<Entry>(
      piezo::host::module_entry("libpiezo_rig_commands.so", "piezo_add_rig_commands"));
  entry(app, commands, std::string(named).c_str());
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"piezo: drive, log and model stick-slip piezoelectric rotary motors"};
  app.set_version_flag("--version",
                       std::string("piezo ") + PIEZO_VERSION + " (" + PIEZO_BUILD_INFO + ")");
  app.require_subcommand(1);
  piezo::host::Commands commands;
  // A model command is built alone and loads no module; `--version` alone
  // needs no command; anything else (a rig command, --help, a misspelt
  // command) loads the rig's.
  const std::string_view named = first_word(argc, argv);
  const bool version_alone = argc == 2 && std::string_view(argv[1]) == "--version";
  if (!version_alone && !piezo::host::add_named_or_all(kModelCommands, named, app, commands)) {
    try {
      add_rig_commands(app, commands, named);
    } catch (const std::exception& e) {
      return report_error(false, kExitFailed, "error", "", e.what());
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return kExitBadInput;
  }
  const bool json = json_asked(app);
  try {
    if (const piezo::host::CommandRunner* run = commands.chosen(app)) return (*run)();
  } catch (const piezo::config::ConfigError& e) {
    return report_error(json, kExitBadInput, "bad_input", e.key(), e.what());
  } catch (const piezo::protocol::ProtocolError& e) {
    return report_error(json, kExitFailed, e.code(), e.key(), e.what());
  } catch (const piezo::host::LinkTimeout& e) {
    return report_error(json, kExitFailed, "no_reply", "", e.what());
  } catch (const std::exception& e) {
    return report_error(json, kExitFailed, "error", "", e.what());
  }
  return kExitFailed;
}
