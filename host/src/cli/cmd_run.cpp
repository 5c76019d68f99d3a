// `piezo run`: drive the rig (real or simulated) for a duration and log it.

#include "run_command.hpp"

namespace piezo::host {

void add_run_command(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<RunOptions>();
  CLI::App* cmd = app.add_subcommand("run", "Drive the rig and log the run");
  add_run_options(*cmd, *o,
                  "Rig config (TOML); a second one overlays the first (e.g. fitted parameters)",
                  "piezod's address, e.g. tcp://board:5555 (default: [rig] address, or the "
                  "firmware in this process)",
                  "Print one JSON summary on stdout");
  cmd->get_option("--config")->required();
  cmd->add_option("--duration", o->duration, "Run time [s] (default: [run] duration_s)")
      ->check(CLI::PositiveNumber);
  cmd->add_flag("--reverse", o->reverse, "Drive the mirrored sawtooth: the rotor turns backwards");
  commands.add(cmd, run_command(cmd, o, {{}, [](const FinishedRun& run) {
                                           return print_run(run, run.result, nullptr);
                                         }}));
}

}  // namespace piezo::host
