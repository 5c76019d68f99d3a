// `piezo report RUN_DIR | FILE`: plots of a logged run -- the measured
// angle with the model's prediction, a zoom on a few drive periods, and the
// drive loop's timing histogram -- from a run directory, or from another
// tool's HDF5, MATLAB v7.3 or CSV file (datasets named as in identify).

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>

#include "commands.hpp"
#include "config/config_file.hpp"
#include "io/columns.hpp"
#include "io/fit_io.hpp"
#include "io/gnuplot.hpp"
#include "io/h5_file.hpp"
#include "io/log_schema.hpp"
#include "io/parameters_json.hpp"
#include "io/run_recovery.hpp"
#include "piezo/config/config_error.hpp"
#include "piezo/model/simulate.hpp"

namespace piezo::host {
namespace {

namespace fs = std::filesystem;

struct ReportOptions {
  std::string input;   ///< a run directory, or a log file
  LogLayout layout;    ///< where another tool's file keeps t, V and theta
  std::string config;  ///< model parameters instead of the log's (Table 1 for a foreign file)
  std::string out;     ///< plots go here; default RUN_DIR/report or FILE's stem + "-report"
  bool json = false;
};

bool is_hdf5(const fs::path& p) {
  const std::string ext = p.extension().string();
  return ext == ".h5" || ext == ".hdf5" || ext == ".mat";
}

std::vector<double> scaled(const std::vector<double>& v, double k) {
  std::vector<double> out(v.size());
  std::transform(v.begin(), v.end(), out.begin(), [k](double x) { return k * x; });
  return out;
}

/// The measured angle beside the model's, over the whole run.
void plot_angle(const fs::path& out, const std::string& title, const std::string& angle_csv) {
  run_gnuplot(fmt::format(
      "set terminal pngcairo size 1000,600 noenhanced\nset output {}\n"
      "set title {}\nset xlabel 't [s]'\nset ylabel 'theta [mrad]'\nset key top left\nset grid\n"
      "plot {} using 1:2 skip 1 with points pt 7 ps 0.2 lc rgb '#1f77b4' title 'measured',"
      " '' using 1:3 skip 1 with lines lw 2 lc rgb '#d62728' title 'model (LuGre, logged drive)'\n",
      gnuplot_quote((out / "angle.png").string()), gnuplot_quote(title + ": rotor angle"),
      gnuplot_quote(angle_csv)));
}

/// The logged sample nearest `t` (`times` sorted, not empty).
double nearest_sample(const std::vector<double>& times, double t) {
  const auto after = std::lower_bound(times.begin(), times.end(), t);
  if (after == times.end()) return times.back();
  if (after == times.begin()) return *after;
  return t - *(after - 1) < *after - t ? *(after - 1) : *after;
}

/// A few drive periods around the middle of the time both the drive and the
/// angle were logged. The window must hold samples of both, or gnuplot finds
/// nothing to plot: a loaded machine's log has gaps where samples were
/// dropped, a run that fell behind logs its drive ahead of its sensor, and a
/// recovered log may have lost the end of either.
void plot_zoom(const fs::path& out, const std::string& title, const LoadedRun& run,
               const std::string& drive_csv, const std::string& angle_csv) {
  const auto& drive_t = run.data.drive_t;
  const auto& t = run.data.t;
  const double both_from = std::max(drive_t.front(), t.front());
  const double both_to = std::min(drive_t.back(), t.back());
  const double middle = both_from <= both_to ? 0.5 * (both_from + both_to) : t[t.size() / 2];
  const double angle_at = nearest_sample(t, middle);
  const double drive_at = nearest_sample(drive_t, angle_at);
  const double half_span = 1.5 / run.parameters.drive.f;
  const double t_from = std::min(angle_at - half_span, drive_at);
  const double t_to = std::max(angle_at + half_span, drive_at);
  run_gnuplot(fmt::format(
      "set terminal pngcairo size 1000,600 noenhanced\nset output {}\n"
      "set title {}\nset xlabel 't [s]'\nset ylabel 'V [V]'\nset y2label 'theta [mrad]'\n"
      "set ytics nomirror\nset y2tics\nset xrange [{}:{}]\nset key top left\nset grid\n"
      "plot {} using 1:2 skip 1 with steps lc rgb '#7f7f7f' title 'drive V' axes x1y1,"
      " {} using 1:2 skip 1 with points pt 7 ps 0.5 lc rgb '#1f77b4' title 'measured theta' axes "
      "x1y2,"
      " '' using 1:3 skip 1 with lines lw 2 lc rgb '#d62728' title 'model theta' axes x1y2\n",
      gnuplot_quote((out / "zoom.png").string()), gnuplot_quote(title + ": three drive periods"),
      t_from, t_to, gnuplot_quote(drive_csv), gnuplot_quote(angle_csv), gnuplot_quote(angle_csv)));
}

/// The drive loop's wake-up lateness histogram, when the log holds one;
/// returns the plot's path ("" without one).
std::string plot_timing(const fs::path& out, const std::string& title,
                        const std::optional<H5File>& log) {
  if (!log || !log->exists(log_schema::kDrivePeriodErrorUs)) return "";
  const auto counts = log->read(log_schema::kDrivePeriodErrorUs);
  std::vector<double> bin_us(counts.size());
  for (std::size_t i = 0; i < bin_us.size(); ++i) bin_us[i] = static_cast<double>(i) + 0.5;
  const std::string timing_csv = (out / "timing.csv").string();
  write_csv(timing_csv, {{"period_error_us", bin_us}, {"cycles", counts}});
  const std::string timing_png = (out / "timing.png").string();
  run_gnuplot(fmt::format(
      "set terminal pngcairo size 1000,600 noenhanced\nset output {}\n"
      "set title {}\nset xlabel 'wake-up lateness [us] (1 us bins)'\nset ylabel 'cycles'\n"
      "set logscale y\nset xrange [0:*]\nset yrange [0.5:*]\nset grid\n"
      "plot {} using 1:($2 > 0 ? $2 : NaN) skip 1 with impulses lw 2 lc rgb '#2ca02c' title "
      "'drive loop'\n",
      gnuplot_quote(timing_png), gnuplot_quote(title + ": drive loop period error"),
      gnuplot_quote(timing_csv)));
  return timing_png;
}

double rmse(const std::vector<double>& measured, const std::vector<double>& predicted) {
  double sum_sq = 0.0;
  for (std::size_t i = 0; i < predicted.size(); ++i) {
    sum_sq += std::pow(measured[i] - predicted[i], 2);
  }
  return std::sqrt(sum_sq / static_cast<double>(predicted.size()));
}

int run(const ReportOptions& o) {
  const bool run_dir = fs::is_directory(o.input);
  const fs::path log_path = run_dir ? fs::path(o.input) / "run.h5" : fs::path(o.input);
  if (run_dir) {
    recover_if_needed(log_path.string());  // a crashed run: rebuilt from its journal first
    if (!fs::exists(log_path))
      throw config::ConfigError(o.input, "run.h5", "no run log in this directory");
  }
  // A piezo run log carries its status and timing; another tool's file not.
  std::optional<H5File> log;
  if (is_hdf5(log_path) && !o.layout.given()) log.emplace(H5File::open(log_path.string()));
  const std::string status = log && log->has_attribute("/", log_schema::kStatus)
                                 ? log->attribute("/", log_schema::kStatus)
                                 : std::string("external log");
  // The log as identification reads it: good angles, and the drive as it
  // reached the output (after the drive's latency, over one period).
  LoadedRun run = load_run_for_fit(log_path.string(), o.layout);
  if (!o.config.empty()) run.parameters = config::load_model_config(o.config);
  const auto predicted = model::predict(run.parameters, run.data, model::FrictionModel::lugre);
  const double error_rad = rmse(run.data.theta, predicted);

  // One axis of a group move's log: its own plots beside the others'.
  const std::string suffix = o.layout.axis.empty() ? "" : "-" + o.layout.axis;
  const fs::path out =
      !o.out.empty() ? fs::path(o.out)
      : run_dir      ? fs::path(o.input) / ("report" + suffix)
                     : log_path.parent_path() / (log_path.stem().string() + "-report" + suffix);
  fs::create_directories(out);
  const std::string angle_csv = (out / "angle.csv").string();
  write_csv(angle_csv, {{"t", run.data.t},
                        {"theta_mrad", scaled(run.data.theta, 1e3)},
                        {"model_mrad", scaled(predicted, 1e3)}});
  const std::string drive_csv = (out / "drive.csv").string();
  write_csv(drive_csv, {{"t", run.data.drive_t}, {"V", run.data.drive_V}});
  const std::string name = run_dir ? fs::absolute(o.input).lexically_normal().filename().string()
                                   : log_path.filename().string();
  const std::string title =
      fmt::format("{}{} ({})", name.empty() ? o.input : name,
                  o.layout.axis.empty() ? "" : ", axis " + o.layout.axis, status);
  plot_angle(out, title, angle_csv);
  plot_zoom(out, title, run, drive_csv, angle_csv);
  const std::string timing_png = plot_timing(out, title, log);

  if (o.json) {
    std::cout << nlohmann::json{{"status", status},
                                {"rmse_model_rad", error_rad},
                                {"angle_png", (out / "angle.png").string()},
                                {"zoom_png", (out / "zoom.png").string()},
                                {"timing_png", timing_png}}
                     .dump()
              << "\n";
  } else {
    fmt::print("run {}: model RMSE {:.4f} mrad over {} samples\n", status, 1e3 * error_rad,
               predicted.size());
    fmt::print("plots in {}\n", out.string());
  }
  return 0;
}

}  // namespace

void add_report_command(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<ReportOptions>();
  CLI::App* cmd = app.add_subcommand("report", "Plot a logged run");
  cmd->add_option("RUN_DIR", o->input,
                  "Run directory (holds run.h5), or a log file: another tool's HDF5 or MATLAB "
                  "v7.3 file (--t, --V, --theta), or a CSV")
      ->required()
      ->check(CLI::ExistingPath);
  add_log_layout_options(*cmd, o->layout);
  add_config_option(*cmd, o->config, "Model parameters (TOML); default: the log's, or Table 1")
      ->check(CLI::ExistingFile);
  add_out_option(*cmd, o->out,
                 "Folder for the plots (default RUN_DIR/report, RUN_DIR/report-AXIS with --axis)");
  add_json_flag(*cmd, o->json);
  commands.add(cmd, [o] { return run(*o); });
}

}  // namespace piezo::host
