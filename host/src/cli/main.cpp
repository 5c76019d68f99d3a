// The `piezo` command line: one binary for the rig and the analyses.

#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <string>

#include "commands.hpp"
#include "config_error.hpp"

namespace {
constexpr int kExitBadInput = 2;
}

int main(int argc, char** argv) {
  CLI::App app{"piezo: drive, log and model stick-slip piezoelectric rotary motors"};
  app.set_version_flag("--version",
                       std::string("piezo ") + PIEZO_VERSION + " (" + PIEZO_BUILD_INFO + ")");
  app.require_subcommand(1);
  const std::vector<piezo::host::CommandRunner> commands{
      piezo::host::add_simulate_command(app), piezo::host::add_sensitivity_command(app),
      piezo::host::add_sweep_command(app),    piezo::host::add_run_command(app),
      piezo::host::add_step_command(app),     piezo::host::add_move_command(app),
      piezo::host::add_calibrate_command(app),
      piezo::host::add_view_command(app),     piezo::host::add_report_command(app),
      piezo::host::add_recover_command(app),  piezo::host::add_sensor_command(app),
      piezo::host::add_rig_sim_command(app),  piezo::host::add_identify_command(app),
      piezo::host::add_compare_command(app),  piezo::host::add_board_commands(app),
  };
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
  try {
    for (const auto& command : commands) {
      if (const int code = command(); code >= 0) return code;
    }
  } catch (const piezo::config::ConfigError& e) {
    fmt::print(stderr, "piezo: error: {}\n", e.what());
    return kExitBadInput;
  } catch (const std::exception& e) {
    fmt::print(stderr, "piezo: error: {}\n", e.what());
    return 1;
  }
  return 1;
}
