#pragma once
// The `piezo` subcommands. Each registers its options on the CLI and what
// it runs (yielding the process's exit code) with `Commands`; main runs the
// one the command line chose.

#include <CLI/CLI.hpp>
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace piezo::host {

using CommandRunner = std::function<int()>;

// The options many commands share, registered one way (each returns its
// option for a command's own checks).
/// --config FILE: `doc` says what the file gives this command.
template <class T>
CLI::Option* add_config_option(CLI::App& cmd, T& config, const std::string& doc) {
  return cmd.add_option("--config", config, doc);
}
/// --out PATH: `doc` says what is written there.
template <class T>
CLI::Option* add_out_option(CLI::App& cmd, T& out, const std::string& doc) {
  return cmd.add_option("--out", out, doc);
}
/// --json: the result as one JSON object on stdout.
inline CLI::Option* add_json_flag(CLI::App& cmd, bool& json,
                                  const std::string& doc = "Print one JSON object on stdout") {
  return cmd.add_flag("--json", json, doc);
}

/// What each subcommand runs, by the subcommand it belongs to.
class Commands {
 public:
  void add(const CLI::App* command, CommandRunner run) {
    runners_.emplace_back(command, std::move(run));
  }
  /// What the command line chose: the deepest parsed subcommand's runner
  /// (`piezo sensor read`'s, not `sensor`'s), or nullptr.
  [[nodiscard]] const CommandRunner* chosen(const CLI::App& app) const {
    for (const CLI::App* sub : app.get_subcommands()) {
      if (const CommandRunner* deeper = chosen(*sub)) return deeper;
      for (const auto& [command, run] : runners_) {
        if (command == sub) return &run;
      }
    }
    return nullptr;
  }

 private:
  std::vector<std::pair<const CLI::App*, CommandRunner>> runners_;
};

/// A command's name on the command line and what adds it. Every command's
/// options cost start-up (CLI11 builds each as objects on the heap), so a
/// command line that names a command builds that one alone.
struct NamedCommand {
  std::string_view name;
  void (*add)(CLI::App& app, Commands& commands);
};

/// Adds the command of `table` that `named` names and says true, or, when
/// it names none of them, adds them all (each add once: entries that share
/// one, as the board's commands do, sit side by side) and says false.
inline bool add_named_or_all(std::span<const NamedCommand> table, std::string_view named,
                             CLI::App& app, Commands& commands) {
  for (const NamedCommand& command : table) {
    if (command.name == named) {
      command.add(app, commands);
      return true;
    }
  }
  for (std::size_t i = 0; i < table.size(); ++i) {
    if (i == 0 || table[i].add != table[i - 1].add) table[i].add(app, commands);
  }
  return false;
}

struct LogLayout;
/// --t, --V, --theta, --theta-t: where another tool's log keeps its data
/// (identify, compare and report read the same files).
void add_log_layout_options(CLI::App& cmd, LogLayout& layout);

void add_simulate_command(CLI::App& app, Commands& commands);
void add_sensitivity_command(CLI::App& app, Commands& commands);
void add_sweep_command(CLI::App& app, Commands& commands);
void add_run_command(CLI::App& app, Commands& commands);
void add_step_command(CLI::App& app, Commands& commands);
void add_move_command(CLI::App& app, Commands& commands);
void add_scan_command(CLI::App& app, Commands& commands);
void add_calibrate_command(CLI::App& app, Commands& commands);
void add_view_command(CLI::App& app, Commands& commands);
void add_report_command(CLI::App& app, Commands& commands);
void add_recover_command(CLI::App& app, Commands& commands);
void add_sensor_command(CLI::App& app, Commands& commands);
void add_rig_sim_command(CLI::App& app, Commands& commands);
void add_identify_command(CLI::App& app, Commands& commands);
void add_compare_command(CLI::App& app, Commands& commands);
void add_board_commands(CLI::App& app, Commands& commands);

}  // namespace piezo::host
