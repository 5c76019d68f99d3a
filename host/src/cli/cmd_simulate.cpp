// `piezo simulate`: one run of the LuGre or Coulomb model from rest.

#include <fmt/format.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <vector>

#include "commands.hpp"
#include "config/config_file.hpp"
#include "config/model_config.hpp"
#include "io/columns.hpp"
#include "io/h5_file.hpp"
#include "io/parameters_json.hpp"
#include "jobs/progress.hpp"
#include "piezo/config/config_error.hpp"
#include "piezo/model/analysis_limits.hpp"
#include "piezo/model/simulate.hpp"
#include "studies/simulate_checks.hpp"

namespace piezo::host {
namespace {

struct SimulateOptions {
  std::string config;
  std::vector<std::string> sets;
  std::string model = "lugre";
  double duration = 4.8;
  double sample_interval = 1e-4;
  double tolerance = model::IntegratorSettings{}.tolerance;
  std::string out;
  bool json = false;
  std::string direction;  // empty: the config's [drive] direction
  std::string integrator = "model_default";
};

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::vector<Column> trajectory_columns(const model::Trajectory& tr) {
  return {{"t", tr.t},         {"V", tr.V},         {"x", tr.x},
          {"x_dot", tr.x_dot}, {"theta", tr.theta}, {"theta_dot", tr.theta_dot},
          {"z", tr.z},         {"F_f", tr.F_f}};
}

void write_trajectory(const std::string& path, const model::Trajectory& tr,
                      const model::Parameters& p, model::FrictionModel m) {
  if (ends_with(path, ".h5")) {
    H5File file = H5File::create(path);
    for (const auto& c : trajectory_columns(tr)) file.write("/" + c.name, c.values);
    file.set_attribute("/", "model", std::string(model::to_string(m)));
    file.set_attribute("/", "parameters", to_json(p).dump());
    return;
  }
  write_csv(path, trajectory_columns(tr));
}

/// Checks that `path` can be written before any work is done (exit 2, not
/// a failure after the simulation).
void require_writable(const std::string& path) {
  std::ofstream probe(path, std::ios::app);
  if (!probe) {
    throw config::ConfigError("--out", path,
                              fmt::format("cannot be written ({})", std::strerror(errno)));
  }
}

int run(const SimulateOptions& o) {
  model::Parameters p =
      o.config.empty() ? model::Parameters{} : config::load_model_config(o.config);
  for (const auto& s : o.sets) config::apply_parameter_override(s, p);
  config::require_valid(p, o.sets.empty() ? (o.config.empty() ? "defaults" : o.config) : "--set");
  const auto friction = checked_friction_model(o.model, "--model");
  if (!o.out.empty() && !ends_with(o.out, ".csv") && !ends_with(o.out, ".h5")) {
    throw config::ConfigError("--out", o.out, "must end in .csv or .h5");
  }
  if (!o.out.empty()) require_writable(o.out);

  if (!o.direction.empty()) p.drive.direction = checked_direction(o.direction, "--direction");
  const model::Sawtooth drive(p.drive.V0, p.drive.f, p.drive.rise());
  // Without --out only the end is reported: the run samples nothing else.
  const auto times = o.out.empty() ? std::vector<double>{o.duration}
                                   : model::uniform_times(o.duration, o.sample_interval);
  const auto integrator = checked_integrator(o.integrator, friction, "--integrator");
  model::IntegratorSettings settings{.tolerance = o.tolerance, .integrator = integrator};
  // Long simulations (minutes of simulated time take seconds to minutes)
  // show how far they are.
  SimulationProgress progress(o.duration, isatty(STDERR_FILENO) != 0,
                              model::differences_from_paper(p));
  settings.progress = [&](double t) { progress(t); };
  const model::Trajectory tr = model::simulate(p.motor, drive, friction, times, settings);
  progress.finish();
  if (!o.out.empty()) write_trajectory(o.out, tr, p, friction);

  const double theta_end = tr.theta.back();
  const double mean_velocity = theta_end / o.duration;
  if (o.json) {
    nlohmann::json j{{"model", o.model},
                     {"direction", model::name(p.drive.direction)},
                     {"duration_s", o.duration},
                     {"theta_end_rad", theta_end},
                     {"mean_velocity_rad_s", mean_velocity},
                     {"parameters", to_json(p)},
                     {"integrator",
                      {{"method", model::to_string(tr.stats.integrator)},
                       {"tolerance", o.tolerance},
                       {"steps", tr.stats.steps},
                       {"rhs_evaluations", tr.stats.rhs_evaluations},
                       {"mode_switches", tr.stats.mode_switches},
                       {"steps_by_mode",
                        {{"series", tr.stats.series_steps},
                         {"linear", tr.stats.linear_steps},
                         {"stick", tr.stats.stick_steps}}}}}};
    std::cout << j.dump() << "\n";
  } else {
    fmt::print("model {}  {}  duration {} s  theta_end {:.6g} rad  mean velocity {:.6g} rad/s\n",
               o.model, model::name(p.drive.direction), o.duration, theta_end, mean_velocity);
    if (!o.out.empty()) fmt::print("trajectory written to {}\n", o.out);
  }
  return 0;
}

}  // namespace

void add_simulate_command(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<SimulateOptions>();
  CLI::App* cmd = app.add_subcommand("simulate", "Simulate the motor from rest");
  add_config_option(*cmd, o->config, "TOML config with [drive] and [model]")
      ->check(CLI::ExistingFile);
  cmd->add_option("--set", o->sets, "Override a parameter: KEY=VALUE (paper symbols, SI)");
  cmd->add_option("--model", o->model, "Friction model: lugre or coulomb")->capture_default_str();
  cmd->add_option("--duration", o->duration, "Simulated time [s], at most an hour")
      ->check(CLI::Validator(
          [](const std::string& text) -> std::string {
            const double v = std::strtod(text.c_str(), nullptr);
            return v > 0.0 && v <= kMaxSimulatedDuration_s
                       ? std::string()
                       : fmt::format("{} s; allowed: (0, {:g}] s", text, kMaxSimulatedDuration_s);
          },
          "(0, 3600]"))
      ->capture_default_str();
  cmd->add_option("--dt", o->sample_interval, "Output sample interval [s]")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--tolerance", o->tolerance, "Integrator tolerance (scaled state)")
      ->check(
          CLI::Range(model::limits::kSimulateTolerance.min, model::limits::kSimulateTolerance.max))
      ->capture_default_str();
  cmd->add_option("--integrator", o->integrator,
                  "hybrid (LuGre: series, linear and stiff modes by event), dopri5 "
                  "(adaptive, both models), closed_form (Coulomb: exact between stick/slip "
                  "switches), or model_default (hybrid for LuGre, closed_form for Coulomb)")
      ->capture_default_str();
  add_out_option(*cmd, o->out, "Write the trajectory: FILE.csv or FILE.h5");
  add_json_flag(*cmd, o->json);
  cmd->add_option("--direction", o->direction,
                  "forward (slow rise, fast fall) or reverse (the mirrored sawtooth)")
      ->capture_default_str();
  commands.add(cmd, [o] { return run(*o); });
}

}  // namespace piezo::host
