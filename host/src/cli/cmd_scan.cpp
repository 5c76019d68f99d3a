// `piezo scan`: a fly scan, logged as a run. An axis turns from --from to
// --to at --velocity (closed loop on its measured angle) and, with
// --trigger-step, fires a trigger pulse on its trigger line at each
// position; each option takes a value for the one axis (--axis, or the
// config's [rig] axis), or AXIS=VALUE once per axis of a group scan.

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "exit_codes.hpp"
#include "piezo/config/config_error.hpp"
#include "piezo/firmware/wire_keys.hpp"
#include "run_command.hpp"

namespace piezo::host {
namespace {

/// One option's values as given: VALUE, or AXIS=VALUE each.
struct PerAxis {
  std::vector<std::string> given;
};

/// A number that is all of `text`, else nullopt.
std::optional<double> number(const std::string& text) {
  std::size_t used = 0;
  try {
    const double value = std::stod(text, &used);
    if (used == text.size()) return value;
  } catch (const std::exception&) {
  }
  return std::nullopt;
}

/// `option`'s values by axis ("" for a plain VALUE: every axis's).
std::map<std::string, double> by_axis(const std::string& option, const PerAxis& p) {
  std::map<std::string, double> out;
  for (const std::string& text : p.given) {
    const std::size_t eq = text.find('=');
    const std::string axis = eq == std::string::npos ? "" : text.substr(0, eq);
    const auto value = number(eq == std::string::npos ? text : text.substr(eq + 1));
    if (!value || eq == 0) {
      throw config::ConfigError(option, text,
                                "a number, or AXIS=NUMBER once per axis of a group scan");
    }
    if (!out.emplace(axis, *value).second) {
      throw config::ConfigError(option, text, "names its axis twice");
    }
  }
  return out;
}

struct ScanOptions {
  PerAxis from, to, velocity, acceleration, deceleration, step, start, end, width, pre_start;
  std::vector<std::string> pulses;
};

/// Each axis's request from the options: the axes are those --from, --to and
/// --velocity name (none: the one axis, ""); every other option's plain
/// value holds for each axis, AXIS=VALUE for that one.
asked::Scan scan_request(const ScanOptions& s, const RunOptions& o) {
  const auto from = by_axis("--from", s.from), to = by_axis("--to", s.to),
             velocity = by_axis("--velocity", s.velocity);
  std::set<std::string> axes;
  for (const auto* m : {&from, &to, &velocity})
    for (const auto& [axis, value] : *m) axes.insert(axis);
  const bool named =
      std::any_of(axes.begin(), axes.end(), [](const std::string& axis) { return !axis.empty(); });
  if (named && axes.contains("")) {
    throw config::ConfigError("--from/--to/--velocity", "",
                              "give a plain value for one axis, or AXIS=VALUE for every axis of a "
                              "group scan, not both");
  }
  if (named && !o.axis.empty()) {
    throw config::ConfigError("--axis", o.axis, "AXIS=VALUE names the scan's axes already");
  }
  const auto value_for = [](const std::map<std::string, double>& m, const std::string& axis,
                            const char* option) -> std::optional<double> {
    if (const auto it = m.find(axis); it != m.end()) return it->second;
    if (const auto it = m.find(""); it != m.end()) return it->second;
    if (option != nullptr) {
      throw config::ConfigError(option, axis.empty() ? std::string("(missing)") : axis + "=?",
                                "required for every axis of the scan");
    }
    return std::nullopt;
  };
  const auto acceleration = by_axis("--acceleration", s.acceleration),
             deceleration = by_axis("--deceleration", s.deceleration),
             step = by_axis("--trigger-step", s.step), start = by_axis("--trigger-start", s.start),
             end = by_axis("--trigger-end", s.end), width = by_axis("--trigger-width", s.width),
             pre_start = by_axis("--trigger-pre-start", s.pre_start),
             pulses = by_axis("--trigger-pulses", PerAxis{s.pulses});
  asked::Scan out;
  for (const std::string& axis : axes) {
    protocol::ScanRequest r;
    r.from_rad = *value_for(from, axis, "--from");
    r.to_rad = *value_for(to, axis, "--to");
    r.velocity_rad_per_s = *value_for(velocity, axis, "--velocity");
    r.acceleration_s = value_for(acceleration, axis, nullptr);
    r.deceleration_s = value_for(deceleration, axis, nullptr);
    r.trigger_step_rad = value_for(step, axis, nullptr);
    r.trigger_start_rad = value_for(start, axis, nullptr);
    r.trigger_end_rad = value_for(end, axis, nullptr);
    r.trigger_width_s = value_for(width, axis, nullptr);
    r.trigger_pre_start_rad = value_for(pre_start, axis, nullptr);
    if (const auto n = value_for(pulses, axis, nullptr)) {
      if (*n < 1 || *n != std::floor(*n)) {
        throw config::ConfigError("--trigger-pulses", fmt::format("{:g}", *n), "a count from 1");
      }
      r.trigger_pulses = static_cast<std::uint64_t>(*n);
    }
    out.scans[axis] = r;
  }
  return out;
}

/// What the host waits for at most: each axis's span at its velocity and
/// half as long again, after an approach of a move's default timeout.
double host_duration_s(const asked::Scan& scan) {
  double longest = 0.0;
  for (const auto& [axis, r] : scan.scans) {
    longest = std::max(longest, 1.5 * std::abs(r.to_rad - r.from_rad) / r.velocity_rad_per_s);
  }
  return firmware::MoveRequest{}.timeout_s + longest;
}

std::string scan_text(const FinishedRun& run) {
  std::string out;
  for (const auto& axis : run.summary.board.axes) {
    if (!axis.scan) continue;
    const protocol::ScanAccount& a = *axis.scan;
    const auto end = a.stop_cause ? firmware::kMoveEndNames.name(*a.stop_cause) : "unknown";
    out += fmt::format("{:<8}{} ({}): {:.6g} -> {:.6g} rad at {:.4g} rad/s\n", a.axis,
                       a.stop_cause == firmware::MoveEnd::on_target ? "scanned" : "NOT scanned",
                       end, a.from_rad, a.to_rad, a.velocity_rad_per_s);
    if (a.measured_velocity_rad_per_s) {
      out += fmt::format(
          "        measured {:.4g} rad/s ({:+.2f} %), ripple {:.3g} rad/s a period, {:.3g} over "
          "ten; the model {:.4g} rad/s at {:.4g} Hz, {:.4g} V\n",
          *a.measured_velocity_rad_per_s,
          100.0 * (*a.measured_velocity_rad_per_s / a.velocity_rad_per_s - 1.0),
          a.ripple_rad_per_s.value_or(NAN), a.ripple_10_rad_per_s.value_or(NAN),
          a.model_velocity_rad_per_s.value_or(NAN), a.mean_f_hz.value_or(NAN),
          a.mean_V.value_or(NAN));
    }
    if (a.triggers) {
      out += fmt::format("        {} of {} pulses every {:.4g} rad from {:.6g} rad, {} late\n",
                         a.triggers->fired, a.triggers->pulses, a.triggers->step_rad,
                         a.triggers->start_rad, a.triggers->late);
    }
  }
  return out;
}

/// `piezo scan --json`: every axis's account (its pulses are in the log).
nlohmann::json scan_json(const FinishedRun& run, bool scanned) {
  nlohmann::json scans = nlohmann::json::object();
  for (const auto& axis : run.summary.board.axes) {
    if (!axis.scan) continue;
    protocol::ScanAccount a = *axis.scan;
    a.pulses.reset();
    scans[a.axis] = a;
  }
  return {{"scanned", scanned},      {"stop_cause", run.summary.stop_cause()},
          {wire_key::scans, scans},  {"run_dir", run.dir.string()},
          {"log", run.log.string()}, {"run", run.result}};
}

void add_per_axis(CLI::App& cmd, const std::string& name, PerAxis& p, const std::string& doc,
                  bool required) {
  auto* option = cmd.add_option(name, p.given, doc + "; AXIS=VALUE (repeated) for each axis");
  if (required) option->required();
}

}  // namespace

void add_scan_command(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<RunOptions>();
  auto s = std::make_shared<ScanOptions>();
  CLI::App* cmd = app.add_subcommand(
      "scan",
      "Fly scan: turn an axis from --from to --to at --velocity (closed loop), a trigger pulse at "
      "each --trigger-step; logged as a run, its pulses in the log (docs/scans.md)");
  add_per_axis(*cmd, "--from", s->from, "Where the span at constant velocity begins [rad]", true);
  add_per_axis(*cmd, "--to", s->to, "Where it ends [rad]", true);
  add_per_axis(*cmd, "--velocity", s->velocity,
               "Mean velocity over the span [rad/s], within the axis's calibrated range", true);
  add_per_axis(*cmd, "--acceleration", s->acceleration,
               "Run-up from the base rate to the velocity [s] (default: the board's, 0.2)", false);
  add_per_axis(*cmd, "--deceleration", s->deceleration,
               "Run-down after the span [s] (default: the acceleration)", false);
  add_per_axis(*cmd, "--trigger-step", s->step,
               "A trigger pulse each time the measured angle passes the next multiple of this "
               "from the start [rad] (default: no triggers)",
               false);
  add_per_axis(*cmd, "--trigger-start", s->start,
               "The first pulse's position [rad] (default: --from)", false);
  add_per_axis(*cmd, "--trigger-end", s->end,
               "The last position a pulse may be at [rad] (default: --to; instead of "
               "--trigger-pulses)",
               false);
  cmd->add_option("--trigger-pulses", s->pulses,
                  "Pulses (default: every position up to --to); AXIS=VALUE (repeated) for each "
                  "axis");
  add_per_axis(*cmd, "--trigger-width", s->width, "Each pulse's high time [s] (default 0.001)",
               false);
  add_per_axis(*cmd, "--trigger-pre-start", s->pre_start,
               "Armed once the angle was this far before the start [rad] (default 0)", false);
  add_run_options(*cmd, *o, "Rig config (TOML), as for `piezo run` (with --rig: default Table 1)",
                  "piezod's address (default: [rig] address, or in-process)",
                  "Print one JSON object: scanned, stop_cause, scans (each axis's account), "
                  "run_dir, log and the run");
  RunProgram program{
      [s, o](config::ConfigFile& config) {
        asked::Scan scan = scan_request(*s, *o);
        config.host.run.duration_s = host_duration_s(scan);
        return scan;
      },
      [](const FinishedRun& run) {
        bool scanned = !run.summary.board.axes.empty();
        for (const auto& axis : run.summary.board.axes) {
          scanned = scanned && axis.scan && axis.scan->stop_cause == firmware::MoveEnd::on_target;
        }
        write_out(stdout, run.options.json ? scan_json(run, scanned).dump() + "\n"
                                           : scan_text(run) + summary_text(run.summary, run.log,
                                                                           run.signal, nullptr));
        if (run.summary.output_state() != "confirmed") {
          write_out(stderr, "piezo: " + output_line(run.summary) + "\n");
        }
        if (exit_code(run.summary) != 0) return exit_code(run.summary);
        return scanned ? 0 : kExitFailed;
      }};
  commands.add(cmd, run_command(cmd, o, std::move(program)));
}

}  // namespace piezo::host
