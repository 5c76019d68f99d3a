// `piezo identify`: fits model parameters to a logged run, or to figures a
// paper reports (--target, target_fit.cpp).

#include <fmt/format.h>

#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "config/config_file.hpp"
#include "config/model_config.hpp"
#include "io/fit_io.hpp"
#include "piezo/config/config_error.hpp"
#include "piezo/model/analysis_limits.hpp"
#include "piezo/model/identify.hpp"
#include "target_fit.hpp"

namespace piezo::host {
namespace {

struct IdentifyOptions {
  LogLayout layout;  ///< where another tool's file keeps t, V and theta
  std::string log;
  std::vector<std::string> targets;  ///< --target: fit to these instead of a log
  std::string params;                ///< empty: the model's defaults
  std::string model = "lugre";
  std::string config;  // start values instead of the log's
  std::string out;
  int max_iterations = model::FitSettings{}.max_iterations;
  bool json = false;
};

int run(const IdentifyOptions& o) {
  if (!o.targets.empty()) {
    return run_target_fit(
        {o.targets, o.params, o.model, o.config, o.out, o.max_iterations, o.json});
  }
  if (o.log.empty()) {
    throw config::ConfigError("command line", "--log", "required, or --target (see --help)");
  }
  const auto friction = model::parse_friction_model(o.model);
  if (!friction) throw config::ConfigError("--model", o.model, "allowed: lugre, coulomb");
  LoadedRun run = load_run_for_fit(o.log, o.layout);
  if (!o.config.empty()) run.parameters = config::load_model_config(o.config);
  model::FitSettings settings = cli_fit_settings(
      checked_free_parameters(
          o.params.empty() ? std::nullopt : std::optional(parse_parameter_list(o.params)),
          *friction, "identify", "--params"),
      *friction, "identify");
  settings.max_iterations = o.max_iterations;
  const model::FitResult r = model::identify(run.parameters, run.data, settings);

  if (!o.out.empty()) {
    write_parameters_toml(o.out, r.parameters,
                          fmt::format("piezo identify --log {} ({} model): RMSE {:.4g} rad", o.log,
                                      o.model, r.rmse_rad));
  }
  if (o.json) {
    nlohmann::json parameters, errors, intervals;
    for (const auto& f : r.fitted) {
      parameters[f.name] = f.value;
      errors[f.name] = f.standard_error;
      intervals[f.name] = {f.low95, f.high95};
    }
    std::cout << nlohmann::json{{"model", o.model},
                                {"parameters", parameters},
                                {"standard_errors", errors},
                                {"confidence_95", intervals},
                                {"rmse_rad", r.rmse_rad},
                                {"initial_rmse_rad", r.initial_rmse_rad},
                                {"iterations", r.iterations},
                                {"converged", r.converged},
                                {"stop_reason", r.stop_reason},
                                {"samples", run.data.t.size()},
                                {"notes", r.notes}}
                     .dump()
              << "\n";
  } else {
    fmt::print(
        "{} model on {} ({} samples): RMSE {:.3f} urad (from {:.3f}) after {} iterations, {}\n",
        o.model, o.log, run.data.t.size(), 1e6 * r.rmse_rad, 1e6 * r.initial_rmse_rad, r.iterations,
        r.stop_reason);
    for (const auto& f : r.fitted) {
      fmt::print("  {:<7} = {:.6g} +- {:.2g}   (95 %: {:.6g} .. {:.6g})\n", f.name, f.value,
                 f.standard_error, f.low95, f.high95);
    }
    for (const auto& note : r.notes) fmt::print("  note: {}\n", note);
    if (!o.out.empty()) fmt::print("fitted parameters written to {}\n", o.out);
  }
  return 0;
}

}  // namespace

void add_identify_command(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<IdentifyOptions>();
  CLI::App* cmd = app.add_subcommand(
      "identify", "Fit model parameters to a logged run, or to reported travel times (--target)");
  CLI::Option* log = cmd->add_option("--log", o->log,
                                     "A run log (run.h5), another tool's HDF5 or MATLAB v7.3 file "
                                     "(--t, --V, --theta), or a CSV")
                         ->check(CLI::ExistingFile);
  cmd->add_option("--target", o->targets,
                  "Instead of a log, a reported figure: the rotor covered ANGLE rad in TIME s "
                  "from rest, with these parameters set (repeat for each; fit at most as many "
                  "--params as targets), e.g. f=20,d_e=0.228e-6,angle=0.010,time=1.36")
      ->excludes(log);
  add_log_layout_options(*cmd, o->layout);
  cmd->add_option("--params", o->params,
                  "Parameters to fit, comma-separated (simulate's keys); default: lugre "
                  "sigma0,sigma1,F_N,d_e, coulomb F_N,d_e");
  cmd->add_option("--model", o->model, "Friction model: lugre or coulomb")->capture_default_str();
  add_config_option(*cmd, o->config,
                    "Start values (TOML [drive]/[model]); default: the log's (with --target: "
                    "Table 1)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--max-iterations", o->max_iterations,
                  "Levenberg-Marquardt iterations at most (a fit stopped here says it did not "
                  "converge)")
      ->capture_default_str()
      ->check(CLI::Range(static_cast<int>(model::limits::kFitIterations.min),
                         static_cast<int>(model::limits::kFitIterations.max)));
  add_out_option(*cmd, o->out, "Write the fitted parameters as TOML");
  add_json_flag(*cmd, o->json);
  commands.add(cmd, [o] { return run(*o); });
}

}  // namespace piezo::host

namespace piezo::host {

void add_log_layout_options(CLI::App& cmd, LogLayout& layout) {
  cmd.add_option("--t", layout.t, "Another tool's file: the time dataset/column [s]");
  cmd.add_option("--V", layout.V, "...the drive voltage's [V]");
  cmd.add_option("--theta", layout.theta, "...the measured angle's [rad]");
  cmd.add_option("--theta-t", layout.theta_t, "...the angle's own time, if not --t's [s]");
  cmd.add_option("--axis", layout.axis,
                 "A log of several axes (a group move): the axis to read (its group /axes/AXIS)");
}

}  // namespace piezo::host
