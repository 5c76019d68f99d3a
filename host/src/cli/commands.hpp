#pragma once
// The `piezo` subcommands. Each registers its options on the CLI and returns
// a callable that runs it and yields the process exit code.

#include <CLI/CLI.hpp>
#include <functional>

namespace piezo::host {

using CommandRunner = std::function<int()>;

struct LogLayout;
/// --t, --V, --theta, --theta-t: where another tool's log keeps its data
/// (identify, compare and report read the same files).
void add_log_layout_options(CLI::App& cmd, LogLayout& layout);

CommandRunner add_simulate_command(CLI::App& app);
CommandRunner add_sensitivity_command(CLI::App& app);
CommandRunner add_sweep_command(CLI::App& app);
CommandRunner add_run_command(CLI::App& app);
CommandRunner add_step_command(CLI::App& app);
CommandRunner add_move_command(CLI::App& app);
CommandRunner add_calibrate_command(CLI::App& app);
CommandRunner add_view_command(CLI::App& app);
CommandRunner add_report_command(CLI::App& app);
CommandRunner add_recover_command(CLI::App& app);
CommandRunner add_sensor_command(CLI::App& app);
CommandRunner add_rig_sim_command(CLI::App& app);
CommandRunner add_identify_command(CLI::App& app);
CommandRunner add_compare_command(CLI::App& app);
CommandRunner add_board_commands(CLI::App& app);

}  // namespace piezo::host
