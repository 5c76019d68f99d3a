#include "calibration_report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <stdexcept>

#include "io/fit_io.hpp"
#include "io/gnuplot.hpp"
#include "piezo/model/identify.hpp"

namespace piezo::host {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

/// The experiment's full-amplitude steps at its fastest reliable frequency
/// (the one moves will use; else the board's own), forward then reverse
/// with the rests after them, from rest, shifted to start at 0 s and 0 rad:
/// under a second of data that shows sticking, slipping and both
/// directions, short enough to fit in seconds.
model::FitData full_amplitude_window(const model::FitData& all, const json& cal,
                                     double sensor_rate_hz, std::pair<double, double>& window) {
  const double V0 = cal.at("V0").get<double>(), D = cal.at("D").get<double>();
  const double f = cal.at("fastest_f_hz").is_number()
                       ? cal.at("fastest_f_hz").get<double>()
                       : cal.at("frequencies").at(0).at("f_hz").get<double>();
  const int steps = cal.at("steps_per_point").get<int>();
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
  const json rest = cal.value("rest_readings", json::object());
  const double rest_s =
      (rest.value("skipped", 10) + rest.value("averaged", 32) + 2) / sensor_rate_hz;
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

json fit_model(const fs::path& log, const json& cal, double sensor_rate_hz) {
  LoadedRun run = load_run_for_fit(log.string());
  std::pair<double, double> window;
  const model::FitData data = full_amplitude_window(run.data, cal, sensor_rate_hz, window);
  fmt::print(stderr, "calibrate: fitting the model to {:.2f} s of full-amplitude steps\n",
             window.second - window.first);
  const model::FitResult r =
      model::identify(run.parameters, data,
                      cli_fit_settings({"sigma0", "sigma1", "F_N", "d_e"},
                                       model::FrictionModel::lugre, "calibrate"));
  json parameters, intervals;
  for (const auto& p : r.fitted) {
    parameters[p.name] = p.value;
    intervals[p.name] = {p.low95, p.high95};
  }
  return {{"friction", "lugre"},
          {"parameters", parameters},
          {"confidence_95", intervals},
          {"rmse_rad", r.rmse_rad},
          {"initial_rmse_rad", r.initial_rmse_rad},
          {"converged", r.converged},
          {"window_s", {window.first, window.second}},
          {"notes", r.notes}};
}

fs::path plot_steps(const fs::path& dir, const json& cal) {
  const fs::path csv = dir / "calibration_steps.csv", png = dir / "calibration.png";
  std::ofstream out(csv);
  out << "f_hz,fraction,forward_urad,reverse_urad\n";
  const auto& fractions = cal.at("step_fractions");
  for (const auto& f : cal.at("frequencies")) {
    for (std::size_t i = 0; i < fractions.size(); ++i) {
      out << fmt::format("{:g},{:g},{:.6g},{:.6g}\n", f.at("f_hz").get<double>(),
                         fractions[i].get<double>(), 1e6 * f.at("forward_rad")[i].get<double>(),
                         -1e6 * f.at("reverse_rad")[i].get<double>());
    }
    out << "\n\n";  // one gnuplot data block per frequency
  }
  out.close();
  std::string plots;
  for (std::size_t k = 0; k < cal.at("frequencies").size(); ++k) {
    const double f = cal.at("frequencies")[k].at("f_hz").get<double>();
    plots += fmt::format(
        "{}{} index {} using ($2*{:g}):3 with linespoints lt {} title '{:g} Hz forward', "
        "{} index {} using ($2*{:g}):4 with linespoints lt {} dt 2 title '{:g} Hz reverse'",
        k == 0 ? "" : ", ", gnuplot_quote(csv.string()), k, cal.at("V0").get<double>(), k + 1, f,
        gnuplot_quote(csv.string()), k, cal.at("V0").get<double>(), k + 1, f);
  }
  run_gnuplot(fmt::format(
      "set terminal pngcairo size 900,560\nset output {}\n"
      "set title 'Step per period as measured (calibration of {})'\n"
      "set xlabel 'amplitude [V]'\nset ylabel 'step per period [urad]'\nset key top left\n"
      "set grid\nset datafile missing 'nan'\nplot {}\n",
      gnuplot_quote(png.string()), cal.value("created", std::string()), plots));
  return png;
}

std::string summary_text(const json& cal, const std::string& kept) {
  const auto urad = [](const json& v) {
    return v.is_number() ? fmt::format("{:.2f}", 1e6 * v.get<double>()) : std::string("-");
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
      cal.at("created").get<std::string>(), cal.at("V0").get<double>(), cal.at("D").get<double>(),
      cal.at("steps_per_point").get<int>(), cal.at("r2_m").get<double>(),
      cal.at("noise_m").get<double>(), urad(cal.at("noise_rad")), urad(cal.at("resolution_rad")),
      urad(cal.at("smallest_tolerance_rad")), 1e6 * cal.at("rad_per_V").get<double>(),
      cal.at("fastest_f_hz").is_number()
          ? fmt::format("{:g} Hz", cal.at("fastest_f_hz").get<double>())
          : std::string("none (no frequency stepped reliably both ways)"),
      kept);
  for (const auto& fr : cal.at("step_fractions")) {
    s += fmt::format(" {:g} V |", fr.get<double>() * cal.at("V0").get<double>());
  }
  s += " reliable | speed [mrad/s] |\n|---|";
  for (std::size_t i = 0; i < cal.at("step_fractions").size() + 2; ++i) s += "---|";
  s += "\n";
  for (const auto& f : cal.at("frequencies")) {
    s += fmt::format("| {:g} |", f.at("f_hz").get<double>());
    for (std::size_t i = 0; i < f.at("forward_rad").size(); ++i) {
      s += fmt::format(" {} / {} |", urad(f.at("forward_rad")[i]),
                       urad(-f.at("reverse_rad")[i].get<double>()));
    }
    s += fmt::format(" {} | {:.2f} |\n", f.at("reliable").get<bool>() ? "yes" : "no",
                     1e3 * f.at("speed_rad_per_s").get<double>());
  }
  const json& m = cal.at("model");
  if (m.is_object()) {
    s += fmt::format(
        "\n## Fitted model (LuGre, {:.2f}-{:.2f} s of the log)\n\nRMSE {:.2f} urad "
        "(from {:.2f} with the start values).\n\n| parameter | value | 95 % |\n"
        "|---|---|---|\n",
        m.at("window_s")[0].get<double>(), m.at("window_s")[1].get<double>(),
        1e6 * m.at("rmse_rad").get<double>(), 1e6 * m.at("initial_rmse_rad").get<double>());
    for (const auto& [name, value] : m.at("parameters").items()) {
      const auto& ci = m.at("confidence_95").at(name);
      s += fmt::format("| {} | {:.6g} | {:.6g} .. {:.6g} |\n", name, value.get<double>(),
                       ci[0].get<double>(), ci[1].get<double>());
    }
    for (const auto& note : m.value("notes", json::array())) {
      s += fmt::format("\nNote: {}\n", note.get<std::string>());
    }
  }
  s += "\n![steps](calibration.png)\n";
  return s;
}

}  // namespace

CalibrationReport finish_calibration(const fs::path& dir, const fs::path& log,
                                     const json& board_calibration, const config::ConfigFile& config,
                                     BoardClient& client, bool local) {
  CalibrationReport report;
  json cal = board_calibration;
  const double sensor_rate_hz = config.board.sensor.rate_hz;
  try {
    cal["model"] = fit_model(log, cal, sensor_rate_hz);
  } catch (const std::exception& e) {
    // The measured table stands without a model: moves use it all the same.
    fmt::print(stderr, "calibrate: warning: no model fitted: {}\n", e.what());
    cal["model"] = nullptr;
  }
  // The board (in this process or at an address) checks it, installs it
  // and says where it keeps it.
  const auto reply = protocol::decode<protocol::SetCalibrationReply>(
      client.call("set_calibration", {{"calibration", cal}}));
  cal = reply.calibration ? json(*reply.calibration) : json(nullptr);
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
  std::ofstream(report.file) << cal.dump(2) << "\n";
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
