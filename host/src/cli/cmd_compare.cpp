// `piezo compare`: the paper's Table III on any log — the Coulomb and the
// LuGre model, each identified on the log, compared by RMSE (paper Eq. 7).

#include <fmt/format.h>

#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "io/columns.hpp"
#include "io/fit_io.hpp"
#include "io/gnuplot.hpp"
#include "io/parameters_json.hpp"

namespace piezo::host {
namespace {

struct CompareOptions {
  LogLayout layout;  ///< where another tool's file keeps t, V and theta
  std::string log;
  std::string out;
  bool json = false;
};

// The friction parameters each model has: LuGre's bristles, Coulomb's level.

nlohmann::json fit_json(const model::FitResult& r) {
  nlohmann::json parameters;
  for (const auto& f : r.fitted) parameters[f.name] = f.value;
  return {{"rmse_rad", r.rmse_rad}, {"parameters", parameters}, {"iterations", r.iterations}};
}

std::vector<double> scaled(const std::vector<double>& v, double k) {
  std::vector<double> out(v);
  for (double& x : out) x *= k;
  return out;
}

void write_overlay(const std::string& dir, const model::FitData& data,
                   const model::FitResult& lugre, const model::FitResult& coulomb) {
  std::filesystem::create_directories(dir);
  const std::string csv = dir + "/compare.csv";
  const auto measured = scaled(data.theta, 1e3), l = scaled(lugre.theta_fit, 1e3),
             c = scaled(coulomb.theta_fit, 1e3);
  write_csv(csv,
            {{"t", data.t}, {"measured_mrad", measured}, {"lugre_mrad", l}, {"coulomb_mrad", c}});
  run_gnuplot(fmt::format(
      "set terminal pngcairo size 1000,600 noenhanced\nset output {}\n"
      "set title 'Measured angle and the two identified models (paper Fig. 13)'\n"
      "set xlabel 't [s]'\nset ylabel 'theta [mrad]'\nset key top left\nset grid\n"
      "plot {} using 1:2 skip 1 with points pt 7 ps 0.3 lc rgb '#7f7f7f' title 'measured',"
      " '' using 1:3 skip 1 with lines lw 2 lc rgb '#d62728' title {},"
      " '' using 1:4 skip 1 with lines lw 2 dt 2 lc rgb '#1f77b4' title {}\n",
      gnuplot_quote(dir + "/compare.png"), gnuplot_quote(csv),
      gnuplot_quote(fmt::format("LuGre, RMSE {:.2f} urad", 1e6 * lugre.rmse_rad)),
      gnuplot_quote(fmt::format("Coulomb, RMSE {:.2f} urad", 1e6 * coulomb.rmse_rad))));
}

int run(const CompareOptions& o) {
  const LoadedRun run = load_run_for_fit(o.log, o.layout);
  const auto lugre =
      model::identify(run.parameters, run.data,
                      cli_fit_settings(model::default_free_parameters(model::FrictionModel::lugre),
                                       model::FrictionModel::lugre, "lugre"));
  const auto coulomb = model::identify(
      run.parameters, run.data,
      cli_fit_settings(model::default_free_parameters(model::FrictionModel::coulomb),
                       model::FrictionModel::coulomb, "coulomb"));
  // How many times smaller the LuGre model's error is (Table III: 2.362 / 0.358 = 6.6).
  const double improvement = coulomb.rmse_rad / lugre.rmse_rad;
  if (!o.out.empty()) write_overlay(o.out, run.data, lugre, coulomb);
  if (o.json) {
    std::cout << nlohmann::json{{"lugre", fit_json(lugre)},
                                {"coulomb", fit_json(coulomb)},
                                {"improvement", improvement},
                                {"samples", run.data.t.size()}}
                     .dump()
              << "\n";
  } else {
    fmt::print("model     RMSE [urad]   (paper Eq. 7, {} samples of {})\n", run.data.t.size(),
               o.log);
    fmt::print("Coulomb   {:10.3f}\nLuGre     {:10.3f}\n", 1e6 * coulomb.rmse_rad,
               1e6 * lugre.rmse_rad);
    fmt::print("LuGre's error is {:.2f} times smaller\n", improvement);
    if (!o.out.empty()) fmt::print("overlay plot: {}/compare.png\n", o.out);
  }
  return 0;
}

}  // namespace

void add_compare_command(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<CompareOptions>();
  CLI::App* cmd =
      app.add_subcommand("compare", "Coulomb against LuGre on a logged run (Table III)");
  cmd->add_option("--log", o->log,
                  "A run log (run.h5), another tool's HDF5 or MATLAB v7.3 file (--t, --V, "
                  "--theta), or a CSV")
      ->required()
      ->check(CLI::ExistingFile);
  add_log_layout_options(*cmd, o->layout);
  add_out_option(*cmd, o->out, "Directory for the overlay plot (paper Fig. 13)");
  add_json_flag(*cmd, o->json);
  commands.add(cmd, [o] { return run(*o); });
}

}  // namespace piezo::host
