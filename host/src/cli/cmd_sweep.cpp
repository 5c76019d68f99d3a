// `piezo sweep`: one parameter over a wide range (by default the drive
// frequency from 1 Hz towards the stator's resonance), LuGre and Coulomb
// side by side: mean velocity, step and backward slip per period.

#include <fmt/format.h>

#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "config/config_file.hpp"
#include "config/model_config.hpp"
#include "io/columns.hpp"
#include "io/gnuplot.hpp"
#include "jobs/interruption.hpp"
#include "jobs/parallel.hpp"
#include "jobs/progress.hpp"
#include "piezo/config/config_error.hpp"
#include "piezo/model/analysis_limits.hpp"
#include "piezo/model/frequency_sweep.hpp"
#include "piezo/model/sensitivity.hpp"

namespace piezo::host {
namespace {

struct SweepOptions {
  std::string config;
  std::vector<std::string> sets;
  std::string param = "f";
  double from = 1.0, to = 2000.0;
  int points = 60;
  bool log = false;
  int periods = 20;
  std::string model = "both";
  std::string out;
  bool json = false;
  // A second parameter makes a 2-D map.
  std::string param2;
  double from2 = 0.0, to2 = 0.0;
  int points2 = 20;
  bool log2 = false;
};

struct Curve {
  model::FrictionModel model;
  std::vector<model::StepMetrics> points;
};

/// Where stick-slip stops working: the first value past the velocity peak
/// at which the mean velocity has fallen below a tenth of the peak's.
double stops_working_at(const std::vector<double>& values, const Curve& c) {
  std::size_t peak = 0;
  for (std::size_t i = 0; i < c.points.size(); ++i) {
    if (c.points[i].mean_velocity_rad_s > c.points[peak].mean_velocity_rad_s) peak = i;
  }
  for (std::size_t i = peak; i < c.points.size(); ++i) {
    if (c.points[i].mean_velocity_rad_s < 0.1 * c.points[peak].mean_velocity_rad_s) {
      return values[i];
    }
  }
  return std::nan("");
}

void write_outputs(const SweepOptions& o, const std::vector<double>& values,
                   const std::vector<Curve>& curves) {
  namespace fs = std::filesystem;
  fs::create_directories(o.out);
  std::vector<std::vector<double>> columns;
  std::vector<Column> csv{{o.param, values}};
  for (const auto& c : curves) {
    std::vector<double> v, step, slip;
    for (const auto& m : c.points) {
      v.push_back(1e3 * m.mean_velocity_rad_s);
      step.push_back(1e6 * m.step_rad);
      slip.push_back(1e6 * m.backslip_rad);
    }
    columns.push_back(std::move(v));
    columns.push_back(std::move(step));
    columns.push_back(std::move(slip));
  }
  for (std::size_t i = 0; i < curves.size(); ++i) {
    const std::string name(model::to_string(curves[i].model));
    csv.push_back({name + "_velocity_mrad_s", columns[3 * i]});
    csv.push_back({name + "_step_urad", columns[3 * i + 1]});
    csv.push_back({name + "_backslip_urad", columns[3 * i + 2]});
  }
  const std::string table = o.out + "/sweep.csv";
  write_csv(table, csv);
  std::string panels;
  const char* titles[3] = {"mean velocity [mrad/s]", "step per period [urad]",
                           "backward slip per period [urad]"};
  for (int k = 0; k < 3; ++k) {
    panels += fmt::format("set ylabel '{}'\nplot ", titles[k]);
    for (std::size_t i = 0; i < curves.size(); ++i) {
      panels += fmt::format("{}{} skip 1 using 1:{} with linespoints lw 2 pt 7 ps 0.6 title '{}'",
                            i == 0 ? "" : ", ", gnuplot_quote(table), 2 + 3 * i + k,
                            model::to_string(curves[i].model));
    }
    panels += "\n";
  }
  run_gnuplot(fmt::format(
      "set terminal pngcairo size 1000,1100\nset output {}\nset datafile separator ','\n"
      "set multiplot layout 3,1 title 'Sweep of {} ({} periods per point)'\nset grid\n{}"
      "set key top right\nset xlabel '{}'\n{}unset multiplot\n",
      gnuplot_quote(o.out + "/sweep.png"), o.param, o.periods, o.log ? "set logscale x\n" : "",
      o.param, panels));
}

/// Two parameters: the mean velocity (and the per-period figures) over the
/// grid, one map per model, as CSV blocks and a colour map.
int run_map(const SweepOptions& o, const model::Parameters& base,
            const std::vector<model::FrictionModel>& models, const std::vector<double>& values) {
  if (o.param2 != "D" && model::find_parameter(o.param2) == nullptr) {
    throw config::ConfigError("--param2", o.param2,
                              "allowed: a Table 1 symbol (V0, f, mu, ...) or D");
  }
  if (!model::limits::kSweepMapPoints.admits(o.points2)) {
    throw config::ConfigError("--points2", std::to_string(o.points2),
                              "allowed: " + model::limits::kSweepMapPoints.text());
  }
  if (o.log2 && !(o.from2 > 0.0 && o.to2 > 0.0)) {
    throw config::ConfigError("--from2", fmt::format("{:g}", o.from2),
                              "a --log2 sweep needs positive --from2 and --to2");
  }
  const auto values2 = model::sweep_values(o.from2, o.to2, o.points2, o.log2);
  const auto at = [&](std::size_t i, std::size_t j) {
    return model::with_level(model::with_level(base, o.param, values[i]), o.param2, values2[j]);
  };
  for (std::size_t i = 0; i < values.size(); ++i) {
    for (std::size_t j = 0; j < values2.size(); ++j) {
      config::require_valid(at(i, j), fmt::format("--param {}={:g}, --param2 {}={:g}", o.param,
                                                  values[i], o.param2, values2[j]));
    }
  }
  const std::size_t cells = values.size() * values2.size();
  std::vector<std::vector<model::StepMetrics>> maps(models.size(),
                                                    std::vector<model::StepMetrics>(cells));
  const model::PeriodSettings settings{o.periods, 2, 200};
  parallel_for(
      cells * models.size(),
      [&](std::size_t job) {
        const std::size_t m = job % models.size(), cell = job / models.size();
        maps[m][cell] = model::period_metrics(at(cell / values2.size(), cell % values2.size()),
                                              models[m], settings, interruptible());
      },
      counted_progress("sweep map", "points"));
  nlohmann::json result{{"param", o.param},
                        {"values", values},
                        {"param2", o.param2},
                        {"values2", values2},
                        {"periods", o.periods}};
  std::string plots;
  for (std::size_t m = 0; m < models.size(); ++m) {
    const std::string name(model::to_string(models[m]));
    nlohmann::json rows = nlohmann::json::array();
    std::string csv =
        fmt::format("{},{},velocity_mrad_s,step_urad,backslip_urad\n", o.param, o.param2);
    for (std::size_t i = 0; i < values.size(); ++i) {
      nlohmann::json row = nlohmann::json::array();
      for (std::size_t j = 0; j < values2.size(); ++j) {
        const auto& c = maps[m][i * values2.size() + j];
        row.push_back(c.mean_velocity_rad_s);
        csv += fmt::format("{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}\n", values[i], values2[j],
                           1e3 * c.mean_velocity_rad_s, 1e6 * c.step_rad, 1e6 * c.backslip_rad);
      }
      rows.push_back(row);
      csv += "\n";  // gnuplot: one block per value of the first parameter
    }
    result[name] = {{"mean_velocity_rad_s", rows}};
    if (!o.out.empty()) {
      std::filesystem::create_directories(o.out);
      const std::string path = fmt::format("{}/map_{}.csv", o.out, name);
      write_text(path, csv);
      plots += fmt::format(
          "set title '{}: mean velocity [mrad/s]'\nsplot {} skip 1 using 1:2:3 with pm3d notitle\n",
          name, gnuplot_quote(path));
    }
  }
  if (!o.out.empty()) {
    run_gnuplot(fmt::format(
        "set terminal pngcairo size {},600\nset output {}\nset datafile separator ','\n"
        "set view map\nset autoscale xfix\nset autoscale yfix\nset palette rgb 33,13,10\nset "
        "xlabel '{}'\nset ylabel '{}'\n{}{}"
        "set multiplot layout 1,{}\n{}unset multiplot\n",
        550 * models.size(), gnuplot_quote(o.out + "/map.png"), o.param, o.param2,
        o.log ? "set logscale x\n" : "", o.log2 ? "set logscale y\n" : "", models.size(), plots));
  }
  if (o.json) {
    std::cout << result.dump() << "\n";
  } else if (!o.out.empty()) {
    fmt::print("map_*.csv and map.png written to {}\n", o.out);
  }
  return 0;
}

int run(const SweepOptions& o) {
  model::Parameters base =
      o.config.empty() ? model::Parameters{} : config::load_model_config(o.config);
  for (const auto& s : o.sets) config::apply_parameter_override(s, base);
  config::require_valid(base, o.sets.empty() ? "config" : "--set");
  if (o.param != "D" && model::find_parameter(o.param) == nullptr) {
    throw config::ConfigError("--param", o.param,
                              "allowed: a Table 1 symbol (V0, f, mu, ...) or D");
  }
  if (!model::limits::kSweepPoints.admits(o.points)) {
    throw config::ConfigError("--points", std::to_string(o.points),
                              "allowed: " + model::limits::kSweepPoints.text());
  }
  if (!model::limits::kSweepPeriods.admits(o.periods)) {
    throw config::ConfigError("--periods", std::to_string(o.periods),
                              "allowed: " + model::limits::kSweepPeriods.text());
  }
  if (o.log && !(o.from > 0.0 && o.to > 0.0)) {
    throw config::ConfigError("--from", fmt::format("{:g}", o.from),
                              "a --log sweep needs positive --from and --to");
  }
  std::vector<model::FrictionModel> models;
  if (o.model == "both") {
    models = {model::FrictionModel::lugre, model::FrictionModel::coulomb};
  } else if (const auto m = model::parse_friction_model(o.model)) {
    models = {*m};
  } else {
    throw config::ConfigError("--model", o.model, "allowed: lugre, coulomb, both");
  }
  const auto values = model::sweep_values(o.from, o.to, o.points, o.log);
  if (!o.param2.empty()) return run_map(o, base, models, values);
  // Every point is checked before any is simulated.
  for (double v : values) {
    config::require_valid(model::with_level(base, o.param, v),
                          fmt::format("--param {}={:g}", o.param, v));
  }
  std::vector<Curve> curves;
  for (auto m : models) curves.push_back({m, std::vector<model::StepMetrics>(values.size())});
  const model::PeriodSettings settings{o.periods, 2, 200};
  parallel_for(
      values.size() * curves.size(),
      [&](std::size_t job) {
        Curve& c = curves[job % curves.size()];
        const std::size_t i = job / curves.size();
        c.points[i] = model::period_metrics(model::with_level(base, o.param, values[i]), c.model,
                                            settings, interruptible());
      },
      counted_progress("sweep", "points"));
  if (!o.out.empty()) write_outputs(o, values, curves);

  nlohmann::json result{{"param", o.param}, {"values", values}, {"periods", o.periods}};
  for (const auto& c : curves) {
    nlohmann::json v = nlohmann::json::array(), step = v, slip = v;
    for (const auto& m : c.points) {
      v.push_back(m.mean_velocity_rad_s);
      step.push_back(m.step_rad);
      slip.push_back(m.backslip_rad);
    }
    const double stops = stops_working_at(values, c);
    result[std::string(model::to_string(c.model))] = {
        {"mean_velocity_rad_s", v},
        {"step_rad", step},
        {"backslip_rad", slip},
        {"stops_working_at", std::isnan(stops) ? nlohmann::json() : nlohmann::json(stops)}};
  }
  if (o.json) {
    std::cout << result.dump() << "\n";
    return 0;
  }
  for (const auto& c : curves) {
    const double stops = stops_working_at(values, c);
    fmt::print("{}: mean velocity from {:.4g} to {:.4g} rad/s over {} = {:g}..{:g}; {}\n",
               model::to_string(c.model), c.points.front().mean_velocity_rad_s,
               c.points.back().mean_velocity_rad_s, o.param, values.front(), values.back(),
               std::isnan(stops)
                   ? std::string("stick-slip works over the whole range")
                   : fmt::format("below a tenth of its peak from {} = {:g}", o.param, stops));
  }
  if (!o.out.empty()) fmt::print("sweep.csv and sweep.png written to {}\n", o.out);
  return 0;
}

}  // namespace

void add_sweep_command(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<SweepOptions>();
  CLI::App* cmd = app.add_subcommand(
      "sweep", "One parameter over a wide range: velocity, step and backward slip per period");
  add_config_option(*cmd, o->config, "TOML config with [drive] and [model] (the baseline)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--set", o->sets, "Override a baseline parameter: KEY=VALUE");
  cmd->add_option("--param", o->param, "The swept parameter (a Table 1 symbol, or D)")
      ->capture_default_str();
  cmd->add_option("--from", o->from, "First value")->capture_default_str();
  cmd->add_option("--to", o->to, "Last value")->capture_default_str();
  cmd->add_option("--points", o->points, "Number of values")->capture_default_str();
  cmd->add_flag("--log", o->log, "Space the values geometrically");
  cmd->add_option("--periods", o->periods, "Drive periods simulated per point")
      ->capture_default_str();
  cmd->add_option("--model", o->model, "lugre, coulomb or both")->capture_default_str();
  cmd->add_option("--param2", o->param2, "A second parameter: a 2-D map of the two");
  cmd->add_option("--from2", o->from2, "First value of --param2");
  cmd->add_option("--to2", o->to2, "Last value of --param2");
  cmd->add_option("--points2", o->points2, "Number of values of --param2")->capture_default_str();
  cmd->add_flag("--log2", o->log2, "Space --param2's values geometrically");
  add_out_option(*cmd, o->out, "Directory for sweep.csv and sweep.png (map_*.csv, map.png)");
  add_json_flag(*cmd, o->json);
  commands.add(cmd, [o] { return run(*o); });
}

}  // namespace piezo::host
