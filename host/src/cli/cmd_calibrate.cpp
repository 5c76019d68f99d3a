// `piezo calibrate`: the board's designed experiment, then the fit, the
// files and the calibration given back to the board
// (calibration_report.cpp).

#include <fmt/format.h>

#include "calibration_report.hpp"
#include "exit_codes.hpp"
#include "run_command.hpp"

namespace piezo::host {
namespace {

/// `piezo calibrate`'s end: the fit, the files and the board told, or why not.
int report_calibration(const FinishedRun& run) {
  const RunSummary& summary = run.summary;
  const RunOptions& o = run.options;
  nlohmann::json result = run.result;
  const auto& measured = summary.board.calibration.value;
  if (!measured || summary.status() != "completed") {
    const std::string why = summary.board.calibration_error
                                ? *summary.board.calibration_error
                                : fmt::format("the run ended {}", summary.stop_cause());
    result["calibration"] = nullptr;
    result["calibration_error"] = why;
    write_out(stdout, o.json ? result.dump() + "\n"
                             : summary_text(summary, run.log, std::string(), nullptr));
    write_out(stderr, fmt::format("piezo: calibration failed: {}\n", why));
    return kExitFailed;
  }
  const CalibrationReport report =
      finish_calibration(run.dir, run.log, *measured, summary.board.axes.at(0).name, run.config,
                         run.board, run.local);
  result["calibration"] = nlohmann::json(report.calibration);
  result["kept"] = report.kept;
  result["files"] = {
      {"calibration", report.file.string()},
      {"plot", report.plot.empty() ? nlohmann::json() : nlohmann::json(report.plot.string())},
      {"summary", report.summary.string()}};
  if (o.json) {
    write_out(stdout, result.dump() + "\n");
  } else {
    const auto& c = report.calibration;
    const auto fit = fit_of(c);
    write_out(
        stdout,
        fmt::format("calibrated: fastest reliable step frequency {}, noise {:.3g} m, "
                    "smallest tolerance {:.3g} rad, {:.4g} urad/V in stick{}\n"
                    "kept {}\nsummary {}\n",
                    c.fastest_f_hz ? fmt::format("{:g} Hz", *c.fastest_f_hz) : std::string("none"),
                    c.noise_m, c.smallest_tolerance_rad.value_or(0.0), 1e6 * c.rad_per_V,
                    fit ? fmt::format(", model fitted (RMSE {:.2f} urad)", 1e6 * fit->rmse_rad)
                        : std::string(),
                    report.kept, report.summary.string()));
  }
  return 0;
}

}  // namespace

void add_calibrate_command(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<RunOptions>();
  CLI::App* cmd = app.add_subcommand(
      "calibrate",
      "Measure the rig (steps both ways at several amplitudes and frequencies, DC holds, the "
      "sensor's noise), fit the model, and give the board the calibration its moves use");
  add_run_options(*cmd, *o, "Rig config (TOML), as for `piezo run` (with --rig: default Table 1)",
                  "piezod's address (default: [rig] address, or in-process)",
                  "Print one JSON object: the calibration, where it is kept, files");
  cmd->add_option("--V0", o->V0, "Peak voltage of the steps [V] (default: the board's [drive] V0)");
  RunProgram program{[o](config::ConfigFile& config) {
                       config.host.run.duration_s =
                           60.0;  // the board's plan says how long; its start reply tells
                       return asked::Calibration{o->V0};
                     },
                     report_calibration};
  commands.add(cmd, run_command(cmd, o, std::move(program)));
}

}  // namespace piezo::host
