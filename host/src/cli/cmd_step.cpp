// `piezo step N`: exactly N whole drive periods, and the travel they made.

#include "run_command.hpp"

namespace piezo::host {

void add_step_command(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<RunOptions>();
  auto count = std::make_shared<std::uint64_t>(0);
  CLI::App* cmd = app.add_subcommand(
      "step", "Drive exactly N periods (steps) and report the measured travel; logged as a run");
  cmd->add_option("count", *count, "Number of steps (whole drive periods)")
      ->required()
      ->check(CLI::Range(std::uint64_t{1}, std::uint64_t{1'000'000}));
  add_run_options(*cmd, *o, "Rig config (TOML), as for `piezo run` (with --rig: default Table 1)",
                  "piezod's address (default: [rig] address, or in-process)",
                  "Print one JSON summary on stdout");
  cmd->add_flag("--reverse", o->reverse, "Step backwards (the mirrored sawtooth)");
  cmd->add_option("--V0", o->V0, "Peak voltage [V] (default: [drive] V0)");
  cmd->add_option("--f", o->f, "Drive frequency [Hz] (default: [drive] f)");
  RunProgram program{[count](config::ConfigFile& config) {
                       config.host.run.duration_s =
                           static_cast<double>(*count) / config.host.model.drive.f;
                       return asked::Periods{*count};
                     },
                     [count](const FinishedRun& run) {
                       const double travel = run.summary.theta_end_rad;
                       const nlohmann::json steps = {
                           {"count", *count},
                           {"direction", model::name(run.config.host.model.drive.direction)},
                           {"travel_rad", travel},
                           {"mean_step_rad", travel / static_cast<double>(*count)}};
                       nlohmann::json result = run.result;
                       result["steps"] = steps;
                       return print_run(run, result, steps);
                     }};
  commands.add(cmd, run_command(cmd, o, std::move(program)));
}

}  // namespace piezo::host
