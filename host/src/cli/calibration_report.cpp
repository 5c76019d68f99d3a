#include "calibration_report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <stdexcept>

#include "io/fit_io.hpp"
#include "io/gnuplot.hpp"
#include "piezo/model/identify.hpp"
#include "piezo/protocol/wire_fields.hpp"

namespace piezo::protocol::wire {
template <>
struct Fields<host::CalibrationFit> {
  using T = host::CalibrationFit;
  static constexpr auto list = std::tuple{field("friction", &T::friction),
                                          field("parameters", &T::parameters),
                                          field("confidence_95", &T::confidence_95),
                                          field("rmse_rad", &T::rmse_rad),
                                          field("initial_rmse_rad", &T::initial_rmse_rad),
                                          field("converged", &T::converged),
                                          field("window_s", &T::window_s),
                                          field("notes", &T::notes, may_be_missing)};
};
}  // namespace piezo::protocol::wire

namespace piezo::host {

void to_json(nlohmann::json& j, const CalibrationFit& m) {
  j = protocol::wire::encode(m);
}
void from_json(const nlohmann::json& j, CalibrationFit& m) {
  protocol::wire::decode_into(j, m);
}

std::optional<CalibrationFit> fit_of(const Calibration& c) {
  if (!c.model.is_object()) return std::nullopt;
  try {
    return protocol::decode<CalibrationFit>(c.model);
  } catch (const protocol::ProtocolError&) {
    return std::nullopt;
  }
}

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

/// The experiment's full-amplitude steps at its fastest reliable frequency
/// (the one moves will use; else the board's own), forward then reverse
/// with the rests after them, from rest, shifted to start at 0 s and 0 rad:
/// under a second of data that shows sticking, slipping and both
/// directions, short enough to fit in seconds.
model::FitData full_amplitude_window(const model::FitData& all, const Calibration& cal,
                                     double sensor_rate_hz, std::pair<double, double>& window) {
  if (cal.frequencies.empty()) throw std::runtime_error("the calibration stepped no frequency");
  const double V0 = cal.V0, D = cal.D;
  const double f = cal.fastest_f_hz.value_or(cal.frequencies.front().f_hz);
  const auto steps = static_cast<int>(cal.steps_per_point);
  // The peaks at V0: the first of a series one period apart is the start.
  std::vector<double> peaks;
  for (std::size_t i = 1; i < all.drive_V.size(); ++i) {
    if (all.drive_V[i] >= 0.995 * V0 && all.drive_V[i - 1] < 0.995 * V0) {
      peaks.push_back(all.drive_t[i]);
    }
  }
  std::size_t first = 0;
  while (first + 1 < peaks.size() &&
         std::abs(peaks[first + 1] - peaks[first] - 1.0 / f) > 0.2 / f) {
    ++first;
  }
  if (first + 1 >= peaks.size()) {
    throw std::runtime_error(fmt::format("the log has no full-amplitude steps at {:g} Hz", f));
  }
  // A record from before the rests were reported: the board's defaults then.
  const auto rest = cal.rest_readings.value_or(Calibration::RestReadings{10, 32});
  const double rest_s = (rest.skipped + rest.averaged + 2) / sensor_rate_hz;
  // The steps begin a rise before the first peak, after a rest whose
  // second half is the rotor at rest: the fit's zero.
  const double steps_begin = peaks[first] - D / f;
  const double begin = steps_begin - 2e-3;
  const double end = steps_begin + 2.0 * steps / f + 2.0 * rest_s;
  window = {begin, end};
  double base = 0.0;
  int n = 0;
  for (std::size_t i = 0; i < all.t.size(); ++i) {
    if (all.t[i] >= steps_begin - 0.5 * rest_s && all.t[i] < begin) {
      base += all.theta[i];
      ++n;
    }
  }
  base = n > 0 ? base / n : 0.0;
  model::FitData w;
  w.ramp_time = all.ramp_time;
  for (std::size_t i = 0; i < all.drive_t.size(); ++i) {
    if (all.drive_t[i] >= begin && all.drive_t[i] <= end) {
      w.drive_t.push_back(all.drive_t[i] - begin);
      w.drive_V.push_back(all.drive_V[i]);
    }
  }
  for (std::size_t i = 0; i < all.t.size(); ++i) {
    if (all.t[i] >= begin && all.t[i] <= end && std::isfinite(all.theta[i])) {
      w.t.push_back(all.t[i] - begin);
      w.theta.push_back(all.theta[i] - base);
    }
  }
  return w;
}

CalibrationFit fit_model(const fs::path& log, const Calibration& cal, double sensor_rate_hz) {
  LoadedRun run = load_run_for_fit(log.string());
  std::pair<double, double> window;
  const model::FitData data = full_amplitude_window(run.data, cal, sensor_rate_hz, window);
  fmt::print(stderr, "calibrate: fitting the model to {:.2f} s of full-amplitude steps\n",
             window.second - window.first);
  const model::FitResult r =
      model::identify(run.parameters, data,
                      cli_fit_settings({"sigma0", "sigma1", "F_N", "d_e"},
                                       model::FrictionModel::lugre, "calibrate"));
  CalibrationFit fit{std::string(to_string(model::FrictionModel::lugre)),
                     {},
                     {},
                     r.rmse_rad,
                     r.initial_rmse_rad,
                     r.converged,
                     {window.first, window.second},
                     r.notes};
  for (const auto& p : r.fitted) {
    fit.parameters[p.name] = p.value;
    fit.confidence_95[p.name] = {p.low95, p.high95};
  }
  return fit;
}

fs::path plot_steps(const fs::path& dir, const Calibration& cal) {
  const fs::path csv = dir / "calibration_steps.csv", png = dir / "calibration.png";
  std::ofstream out(csv);
  out << "f_hz,fraction,forward_urad,reverse_urad\n";
  const auto& fractions = cal.step_fractions;
  for (const auto& f : cal.frequencies) {
    for (std::size_t i = 0; i < fractions.size(); ++i) {
      out << fmt::format("{:g},{:g},{:.6g},{:.6g}\n", f.f_hz, fractions[i],
                         1e6 * f.forward_rad.at(i), -1e6 * f.reverse_rad.at(i));
    }
    out << "\n\n";  // one gnuplot data block per frequency
  }
  out.close();
  std::string plots;
  for (std::size_t k = 0; k < cal.frequencies.size(); ++k) {
    const double f = cal.frequencies[k].f_hz;
    plots += fmt::format(
        "{}{} index {} using ($2*{:g}):3 with linespoints lt {} title '{:g} Hz forward', "
        "{} index {} using ($2*{:g}):4 with linespoints lt {} dt 2 title '{:g} Hz reverse'",
        k == 0 ? "" : ", ", gnuplot_quote(csv.string()), k, cal.V0, k + 1, f,
        gnuplot_quote(csv.string()), k, cal.V0, k + 1, f);
  }
  run_gnuplot(fmt::format(
      "set terminal pngcairo size 900,560\nset output {}\n"
      "set title 'Step per period as measured (calibration of {})'\n"
      "set xlabel 'amplitude [V]'\nset ylabel 'step per period [urad]'\nset key top left\n"
      "set grid\nset datafile missing 'nan'\nplot {}\n",
      gnuplot_quote(png.string()), cal.created, plots));
  return png;
}

std::string summary_text(const Calibration& cal, const std::string& kept) {
  const auto urad = [](std::optional<double> v) {
    return v ? fmt::format("{:.2f}", 1e6 * *v) : std::string("-");
  };
  std::string s = fmt::format(
      "# Calibration of {}\n\n"
      "Steps at V0 = {:g} V (rise fraction {:.4g}), {} periods per point; the sensor at "
      "r2 = {:g} m.\n\n"
      "- Sensor noise: {:.3g} m a reading ({} urad); resolution {} urad; smallest tolerance a "
      "move may ask for: {} urad.\n"
      "- Angle per volt while the rotor sticks: {:.4g} urad/V.\n"
      "- Fastest reliable step frequency: {}.\n"
      "- Kept: {}.\n\n"
      "## Step per period [urad] (forward / reverse)\n\n| f [Hz] |",
      cal.created, cal.V0, cal.D, cal.steps_per_point, cal.r2_m, cal.noise_m, urad(cal.noise_rad),
      urad(cal.resolution_rad), urad(cal.smallest_tolerance_rad), 1e6 * cal.rad_per_V,
      cal.fastest_f_hz ? fmt::format("{:g} Hz", *cal.fastest_f_hz)
                       : std::string("none (no frequency stepped reliably both ways)"),
      kept);
  for (const double fraction : cal.step_fractions) s += fmt::format(" {:g} V |", fraction * cal.V0);
  s += " reliable | speed [mrad/s] |\n|---|";
  for (std::size_t i = 0; i < cal.step_fractions.size() + 2; ++i) s += "---|";
  s += "\n";
  for (const auto& f : cal.frequencies) {
    s += fmt::format("| {:g} |", f.f_hz);
    for (std::size_t i = 0; i < f.forward_rad.size(); ++i) {
      s += fmt::format(" {} / {} |", urad(f.forward_rad[i]), urad(-f.reverse_rad.at(i)));
    }
    s += fmt::format(" {} | {:.2f} |\n", f.reliable.value_or(false) ? "yes" : "no",
                     1e3 * f.speed_rad_per_s.value_or(0.0));
  }
  if (const auto m = fit_of(cal)) {
    s += fmt::format(
        "\n## Fitted model (LuGre, {:.2f}-{:.2f} s of the log)\n\nRMSE {:.2f} urad "
        "(from {:.2f} with the start values).\n\n| parameter | value | 95 % |\n"
        "|---|---|---|\n",
        m->window_s.at(0), m->window_s.at(1), 1e6 * m->rmse_rad, 1e6 * m->initial_rmse_rad);
    for (const auto& [name, value] : m->parameters) {
      const auto& ci = m->confidence_95.at(name);
      s += fmt::format("| {} | {:.6g} | {:.6g} .. {:.6g} |\n", name, value, ci.at(0), ci.at(1));
    }
    for (const auto& note : m->notes) s += fmt::format("\nNote: {}\n", note);
  }
  s += "\n![steps](calibration.png)\n";
  return s;
}

}  // namespace

CalibrationReport finish_calibration(const fs::path& dir, const fs::path& log,
                                     const Calibration& board_calibration, const std::string& axis,
                                     const config::ConfigFile& config, BoardClient& client,
                                     bool local) {
  CalibrationReport report;
  Calibration cal = board_calibration;
  const double sensor_rate_hz = config.board.sensor_rate_hz;
  try {
    cal.model = json(fit_model(log, cal, sensor_rate_hz));
  } catch (const std::exception& e) {
    // The measured table stands without a model: moves use it all the same.
    fmt::print(stderr, "calibrate: warning: no model fitted: {}\n", e.what());
    cal.model = nullptr;
  }
  // The board (in this process or at an address) checks it, installs it
  // and says where it keeps it.
  const auto reply = protocol::decode<protocol::SetCalibrationReply>(
      client.call("set_calibration", {{"calibration", json(cal)}, {wire_key::axis, axis}}));
  if (!reply.calibration) throw std::runtime_error("the board installed no calibration");
  cal = *reply.calibration;
  if (reply.save_error) {
    throw std::runtime_error(
        fmt::format("the board could not keep the calibration: {}", *reply.save_error));
  }
  const auto& saved_to = reply.saved_to;
  if (!local) {
    const std::string where =
        saved_to ? fmt::format(" (in its {})", *saved_to) : " (in its memory only)";
    report.kept = fmt::format("by the board at {}{}", client.address(), where);
  } else if (saved_to) {
    report.kept = fmt::format(
        "in {} ([piezod] calibration_file): in-process moves with this "
        "config use it",
        *saved_to);
  } else {
    report.kept =
        "only in this run directory (set [piezod] calibration_file to keep it for "
        "in-process moves, or calibrate piezod with --rig)";
  }
  report.calibration = cal;
  report.file = dir / "calibration.json";
  std::ofstream(report.file) << json(cal).dump(2) << "\n";
  try {
    report.plot = plot_steps(dir, cal);
  } catch (const std::exception& e) {
    fmt::print(stderr, "calibrate: warning: no plot: {}\n", e.what());
  }
  report.summary = dir / "calibration.md";
  std::ofstream(report.summary) << summary_text(cal, report.kept);
  return report;
}

}  // namespace piezo::host
