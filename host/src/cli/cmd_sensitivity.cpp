// `piezo sensitivity`: the paper's section 5 study (four parameters, five
// levels, 4.8 s each), with tables and plots of Figs. 14-22.

#include <fmt/format.h>

#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "config/config_file.hpp"
#include "config/model_config.hpp"
#include "io/columns.hpp"
#include "io/gnuplot.hpp"
#include "piezo/config/config_error.hpp"
#include "piezo/model/sensitivity.hpp"
#include "studies/global_sensitivity_study.hpp"
#include "studies/oat_study.hpp"

namespace piezo::host {
namespace {

struct SensitivityOptions {
  std::string config;
  std::vector<std::string> sets;
  std::string model = "lugre";
  std::string out;
  bool json = false;
  std::string method = "oat";
  std::string params;  // comma-separated
  GlobalStudyOptions global;
};

void write_outputs(const std::string& dir, const std::vector<model::SweepResult>& results,
                   const std::vector<LevelRun>& runs) {
  namespace fs = std::filesystem;
  fs::create_directories(dir);
  std::string comparison_plot;
  for (std::size_t s = 0; s < results.size(); ++s) {
    const auto& r = results[s];
    std::vector<double> relative_level, relative_velocity;
    const std::size_t mid = r.levels.size() / 2;
    for (std::size_t i = 0; i < r.levels.size(); ++i) {
      relative_level.push_back(100.0 * (r.levels[i] / r.levels[mid] - 1.0));
      relative_velocity.push_back(100.0 * (r.mean_velocity[i] / r.mean_velocity[mid] - 1.0));
    }
    const std::string table = fmt::format("{}/velocity_{}.csv", dir, r.name);
    write_csv(table, {{"level", r.levels},
                      {"mean_velocity_rad_s", r.mean_velocity},
                      {"level_change_pct", relative_level},
                      {"velocity_change_pct", relative_velocity}});

    std::vector<Column> trace_columns;
    std::vector<std::vector<double>> theta_mrad(r.levels.size());
    for (const auto& run : runs) {
      if (run.sweep != s) continue;
      if (trace_columns.empty()) trace_columns.push_back({"t", run.trace.t});
      for (double th : run.trace.theta) theta_mrad[run.level].push_back(1e3 * th);
    }
    for (std::size_t i = 0; i < r.levels.size(); ++i) {
      trace_columns.push_back({fmt::format("{} = {:g}", r.name, r.levels[i]), theta_mrad[i]});
    }
    const std::string traces = fmt::format("{}/angle_{}.csv", dir, r.name);
    write_csv(traces, trace_columns);

    std::string angle_plot = fmt::format(
        "set terminal pngcairo size 900,600\nset output {}\nset key left top autotitle "
        "columnhead\nset grid\nset xlabel 'time [s]'\nset ylabel 'rotor angle [mrad]'\n"
        "set title 'Rotor angle for five levels of {}'\nplot for [i=2:{}] {} using 1:i with lines "
        "lw 2\n",
        gnuplot_quote(fmt::format("{}/angle_{}.png", dir, r.name)), r.name, r.levels.size() + 1,
        gnuplot_quote(traces));
    std::string velocity_plot = fmt::format(
        "set terminal pngcairo size 900,600\nset output {}\nunset key\nset grid\n"
        "set xlabel '{}'\nset ylabel 'mean velocity [rad/s]'\nset title 'Mean velocity against "
        "{} (elasticity {:.3g})'\nplot {} skip 1 using 1:2 with linespoints lw 2 pt 7\n",
        gnuplot_quote(fmt::format("{}/velocity_{}.png", dir, r.name)), r.name, r.name, r.elasticity,
        gnuplot_quote(table));
    run_gnuplot(angle_plot);
    run_gnuplot(velocity_plot);
    comparison_plot +=
        fmt::format("{}{} skip 1 using 3:4 with linespoints lw 2 pt 7 title '{}'",
                    comparison_plot.empty() ? "plot " : ", ", gnuplot_quote(table), r.name);
  }
  run_gnuplot(
      fmt::format("set terminal pngcairo size 900,600\nset output {}\nset grid\nset key left top\n"
                  "set xlabel 'parameter change [%]'\nset ylabel 'mean velocity change [%]'\n"
                  "set title 'Sensitivity of mean velocity (paper Fig. 22)'\n{}\n",
                  gnuplot_quote(dir + "/comparison.png"), comparison_plot));
}

int run(const SensitivityOptions& o) {
  model::Parameters base =
      o.config.empty() ? model::Parameters{} : config::load_model_config(o.config);
  for (const auto& s : o.sets) config::apply_parameter_override(s, base);
  config::require_valid(base, o.sets.empty() ? "config" : "--set");
  const auto friction = model::parse_friction_model(o.model);
  if (!friction) throw config::ConfigError("--model", o.model, "allowed: lugre, coulomb");
  if (o.method == "morris" || o.method == "sobol") {
    GlobalStudyOptions g = o.global;
    g.method = o.method;
    if (g.samples == 0) g.samples = default_samples(g.method);
    g.model = *friction;
    g.out = o.out;
    g.json = o.json;
    for (std::size_t at = 0; at < o.params.size();) {
      const std::size_t comma = std::min(o.params.find(',', at), o.params.size());
      if (comma > at) g.params.push_back(o.params.substr(at, comma - at));
      at = comma + 1;
    }
    return run_global_study(base, g);
  }
  if (o.method != "oat") {
    throw config::ConfigError("--method", o.method, "allowed: oat, morris, sobol");
  }

  const OatStudy study = oat_study(base, *friction);
  const auto& results = study.results;
  const auto& ranking = study.ranking;
  if (!o.out.empty()) write_outputs(o.out, results, study.runs);

  if (o.json) {
    std::cout << to_json(study, o.model).dump() << "\n";
    return 0;
  }
  for (const auto& r : results) {
    fmt::print("{:>3}  levels {}  mean velocity [rad/s] {:.5f}  elasticity {:+.3f}\n", r.name,
               fmt::join(r.levels, " "), fmt::join(r.mean_velocity, " "), r.elasticity);
  }
  fmt::print("ranking by influence: {}\n", fmt::join(ranking, " > "));
  if (!o.out.empty()) fmt::print("tables and plots written to {}\n", o.out);
  return 0;
}

}  // namespace

void add_sensitivity_command(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<SensitivityOptions>();
  CLI::App* cmd = app.add_subcommand("sensitivity", "The paper's section 5 sensitivity study");
  add_config_option(*cmd, o->config, "TOML config with [drive] and [model] (the baseline)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--set", o->sets, "Override a baseline parameter: KEY=VALUE");
  cmd->add_option("--model", o->model, "Friction model: lugre or coulomb")->capture_default_str();
  add_out_option(*cmd, o->out, "Directory for CSV tables and PNG plots");
  add_json_flag(*cmd, o->json);
  cmd->add_option("--method", o->method,
                  "oat (the paper's study), morris (elementary effects) or sobol (indices)")
      ->capture_default_str();
  cmd->add_option("--params", o->params,
                  "morris/sobol: comma-separated parameters (default: every Table 1 symbol)");
  cmd->add_option("--range", o->global.range_pct, "morris/sobol: each parameter varies by ± this %")
      ->capture_default_str();
  cmd->add_option("--samples", o->global.samples,
                  "sobol: N (runs: N (k + 2), default 1024); morris: trajectories (default 20)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--seed", o->global.seed, "morris/sobol: design and bootstrap seed")
      ->capture_default_str();
  cmd->add_option("--output", o->global.output, "morris/sobol: velocity, step or backslip")
      ->capture_default_str();
  cmd->add_option("--runtime", o->global.runtime_s, "morris/sobol: simulated time per run [s]")
      ->capture_default_str();
  cmd->add_option("--bootstrap", o->global.bootstrap,
                  "sobol: bootstrap resamples for the intervals")
      ->capture_default_str();
  commands.add(cmd, [o] { return run(*o); });
}

}  // namespace piezo::host
