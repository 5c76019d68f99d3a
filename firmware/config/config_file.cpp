#include "config_file.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <variant>

#include "model_config.hpp"
#include "piezo/config/config_error.hpp"
#include "piezo/config/section_reader.hpp"
#include "piezo/firmware/request_limits.hpp"
#include "piezo/model/analysis_limits.hpp"
#include "piezo/overload.hpp"

namespace piezo::config {
namespace {

const std::vector<std::string> kRequiredSections{"drive", "sensor", "run"};

/// A kind's `backend` key, and the keys that moved from its section into
/// the backends' refused naming their new place.
template <class Base>
void choose_backend(SectionReader& r, Backends<Base>& kind) {
  std::vector<std::string> names;
  std::map<std::string, std::vector<std::string>> moved;
  for (const auto& b : kind.all) {
    names.emplace_back(b->name());
    for (const hal::MovedKey& m : b->moved_keys())
      moved[std::string(m.old_key)].emplace_back(m.new_key);
  }
  r.choice("backend", kind.backend, names);
  for (const auto& [old_key, now] : moved) r.moved(old_key, now);
}

/// Every backend's own section ([KIND.SECTION]), read by the backend.
template <class Base>
void read_backend_sections(SectionReader& r, Backends<Base>& kind) {
  for (const auto& b : kind.all) {
    SectionReader own = r.subsection(std::string(b->section()));
    b->read(own);
    own.finish();
  }
}

void read_drive(SectionReader r, DriveSettings& d, model::Parameters& waveform) {
  choose_backend(r, d.backends);
  read_waveform(r, waveform);
  r.number("rate_hz", d.rate_hz, {100.0, 100'000.0}, "Hz");
  r.number("V_min", d.limits.V_min, {0.0, 1000.0}, "V");
  r.number("V_max", d.limits.V_max, {0.0, 1000.0, true}, "V");
  r.number("slew_V_per_s", d.limits.slew_V_per_s, kPositive, "V/s");
  r.number("amplifier_gain", d.amplifier_gain, {0.0, 1000.0, true});
  read_backend_sections(r, d.backends);
  r.finish();
}

void read_sensor(SectionReader r, SensorSettings& s) {
  choose_backend(r, s.backends);
  r.number("rate_hz", s.rate_hz, {1.0, 100'000.0}, "Hz");
  r.number("r2_m", s.r2_m, {0.0, 10.0, true}, "m");
  r.number("range_min_m", s.range_min_m, {-1e3, 1e3}, "m");
  r.number("range_max_m", s.range_max_m, {-1e3, 1e3}, "m");
  read_backend_sections(r, s.backends);
  r.finish();
}

void read_lines(SectionReader r, LinesSettings& l) {
  choose_backend(r, l.backends);
  read_backend_sections(r, l.backends);
  r.finish();
}

/// [run]: the host's keys and the board's share the section.
void read_run(SectionReader r, RunSettings& run, BoardRunSettings& board) {
  r.number("duration_s", run.duration_s, {0.0, 1e6, true}, "s");
  r.choice("clock", board.clock, kRunClockNames);
  r.integer("priority", board.priority, 0, 99);
  r.flag("lock_memory", board.lock_memory);
  r.number("flush_interval_s", run.flush_interval_s, {0.01, 1.0}, "s");
  r.finish();
}

/// [move]: the defaults of `piezo move`'s options, one key per declared
/// field of a move's request (all but the target).
void read_move(SectionReader r, firmware::MoveRequest& m) {
  for (const firmware::MoveField& field : firmware::kMoveFields) {
    if (field.required) continue;
    const std::string key(field.name);
    std::visit(Overload{
                   [&](double firmware::MoveRequest::*p) {
                     r.number(key, m.*p, field.allowed, std::string(field.unit));
                   },
                   [&](std::uint64_t firmware::MoveRequest::*p) {
                     int v = static_cast<int>(m.*p);
                     r.integer(key, v, static_cast<int>(field.allowed.min),
                               static_cast<int>(field.allowed.max));
                     m.*p = static_cast<std::uint64_t>(v);
                   },
                   [&](bool firmware::MoveRequest::*p) { r.flag(key, m.*p); },
                   [&](firmware::Approach firmware::MoveRequest::*p) {
                     r.choice(key, m.*p, firmware::kApproachNames);
                   },
               },
               field.member);
  }
  r.finish();
}

void read_rig_sim(SectionReader r, hal::sim::ModbusDeviceFaults& f, hal::sim::TcpLimits& tcp) {
  r.integer("max_clients", tcp.max_clients, 1, 100'000);
  r.number("frame_timeout_s", tcp.frame_timeout_s, {0.001, 60.0}, "s");
  r.number("response_delay_s", f.response_delay_s, {0.0, 10.0}, "s");
  r.number("drop_probability", f.drop_probability, {0.0, 1.0});
  r.number("exception_probability", f.exception_probability, {0.0, 1.0});
  r.number("disconnect_at_s", f.disconnect_at_s, kNonNegative, "s");
  r.number("late_reply_at_s", f.late_reply_at_s, kNonNegative, "s");
  r.number("late_reply_s", f.late_reply_s, {0.0, 10.0}, "s");
  r.number("hang_at_s", f.hang_at_s, kNonNegative, "s");
  r.number("hang_for_s", f.hang_for_s, {0.0, 3600.0}, "s");
  r.flag("times_from_drive", f.times_from_drive);
  r.finish();
}

void read_observer(SectionReader r, ObserverSettings& o) {
  r.flag("enabled", o.enabled);
  r.number("alpha", o.gains.alpha, model::limits::kObserverAlpha);
  r.number("beta", o.gains.beta, model::limits::kObserverBeta);
  r.number("gate_rad", o.gains.gate_rad, model::limits::kObserverGate_rad, "rad");
  r.finish();
}

void read_daemon(SectionReader r, DaemonSettings& d) {
  r.text("listen", d.listen);
  r.number("lease_s", d.lease_s, {0.05, 60.0}, "s");
  r.number("lease_max_s", d.lease_max_s, {0.05, 600.0}, "s");
  r.number("recorder_s", d.recorder_s, {1.0, 3600.0}, "s");
  r.text("spill_file", d.spill_file);
  r.text("calibration_file", d.calibration_file);
  r.number("duration_max_s", d.duration_max_s, {0.0, 1e7, true}, "s");
  r.number("fetch_samples_per_s", d.fetch_samples_per_s, {1e3, 1e9}, "samples/s");
  r.text("secret_key_file", d.secret_key_file);
  r.text("authorized_keys_file", d.authorized_keys_file);
  r.flag("insecure", d.insecure);
  r.finish();
}

void read_board_address(SectionReader r, BoardAddress& a) {
  r.text("address", a.address);
  r.number("lease_s", a.lease_s, {0.0, 600.0}, "s");
  r.text("server_public_key_file", a.server_public_key_file);
  r.text("client_secret_key_file", a.client_secret_key_file);
  r.finish();
}

void read_safety(SectionReader r, firmware::SafetySettings& s) {
  r.number("sensor_stale_s", s.sensor_stale_s, {0.0, 60.0, true}, "s");
  int sensor_errors = static_cast<int>(s.max_sensor_errors);
  int drive_errors = static_cast<int>(s.max_drive_errors);
  r.integer("max_sensor_errors", sensor_errors, 1, 1'000'000);
  r.integer("max_drive_errors", drive_errors, 1, 1'000'000);
  s.max_sensor_errors = static_cast<std::uint32_t>(sensor_errors);
  s.max_drive_errors = static_cast<std::uint32_t>(drive_errors);
  r.number("ramp_down_V_per_s", s.ramp_down_V_per_s, kPositive, "V/s");
  r.number("stop_confirm_s", s.stop_confirm_s, {0.01, 30.0}, "s");
  r.number("travel_min_rad", s.travel_min_rad, {-10.0, 10.0}, "rad");
  r.flag("protect_runs", s.protect_runs);
  r.integer("stall_periods", s.stall_periods, 1, 16);
  r.number("travel_max_rad", s.travel_max_rad, {-10.0, 10.0}, "rad");
  r.finish();
}

/// Everything one table (the file, or one --set) says, read over `c`: each
/// section into the part of the process that reads it. [plant] keys are
/// collected apart: the plant is [model] overlaid with them.
void read_tables(const toml::table& t, const std::string& source, ConfigFile& c,
                 model::MotorParameters& plant_keys, KeyDeclarations* declarations = nullptr) {
  TableReader file(t, source, declarations);
  BoardConfig& board = c.board;
  HostConfig& host = c.host;
  read_drive(file.section("drive"), board.drive, board.model);
  SectionReader model = file.section("model");
  read_motor(model, board.model.motor);
  model.finish();
  // The waveform and the model are the board's defaults and what the host's
  // run asks for: one file says both.
  host.model = board.model;
  SectionReader plant = file.section("plant");
  read_motor(plant, plant_keys);
  plant.number("end_stop_rad", board.plant_end_stop_rad, {-10.0, 10.0}, "rad");
  plant.finish();
  read_sensor(file.section("sensor"), board.sensor);
  read_lines(file.section("lines"), board.lines);
  read_run(file.section("run"), host.run, board.run);
  read_move(file.section("move"), host.run.move_defaults);
  read_safety(file.section("safety"), board.safety);
  read_rig_sim(file.section("rig_sim"), c.rig_sim.faults, c.rig_sim.tcp);
  read_observer(file.section("observer"), host.observer);
  read_daemon(file.section("piezod"), board.daemon);
  read_board_address(file.section("rig"), host.board);
  file.finish();
}

/// "SECTION.KEY=VALUE" as a one-key TOML table; VALUE is read as TOML
/// (numbers, true/false, "strings"), and a bare word as a string.
toml::table override_table(const std::string& assignment) {
  const auto eq = assignment.find('=');
  const auto dot = assignment.find('.');
  if (eq == std::string::npos || dot == std::string::npos || dot > eq) {
    throw ConfigError("--set", assignment, "expected SECTION.KEY=VALUE, e.g. drive.V0=70");
  }
  const std::string section = assignment.substr(0, dot);
  // SECTION.KEY, or SECTION.BACKEND.KEY for a backend's own section.
  std::string key = assignment.substr(dot + 1, eq - dot - 1);
  std::string backend;
  if (const auto inner_dot = key.find('.'); inner_dot != std::string::npos) {
    backend = key.substr(0, inner_dot);
    key = key.substr(inner_dot + 1);
  }
  const std::string value = assignment.substr(eq + 1);
  require_ascii_outside_comments(assignment, "--set");
  toml::table parsed;
  try {
    parsed = toml::parse("v = " + value);
  } catch (const toml::parse_error&) {
    parsed = toml::table{{"v", value}};
  }
  toml::table inner;
  inner.insert(key, *parsed.get("v"));
  if (!backend.empty()) inner = toml::table{{backend, inner}};
  return toml::table{{section, inner}};
}

/// The plant: [model] with each [plant] key that was given (NaN marks absent).
model::MotorParameters overlay(const model::MotorParameters& base,
                               const model::MotorParameters& keys) {
  model::Parameters out{{}, base};
  model::Parameters given{{}, keys};
  for (const auto& spec : model::parameter_specs()) {
    if (spec.section != "model") continue;
    if (const double v = spec.ref(given); !std::isnan(v)) spec.ref(out) = v;
  }
  return out.motor;
}

model::MotorParameters all_nan() {
  model::Parameters p;
  for (const auto& spec : model::parameter_specs())
    if (spec.section == "model") spec.ref(p) = std::nan("");
  return p.motor;
}

/// Each backend's section as a whole (every one: rig-sim serves the
/// devices a config names even when the run chooses others), and the
/// chosen ones' needs.
template <class Base, class Common>
void check_each(const Backends<Base>& kind, const Common& common, const hal::SourceOf& src) {
  for (const auto& b : kind.all) b->check(common, b->name() == kind.backend, src);
}

void check_backends(const BoardConfig& c, const hal::SourceOf& src) {
  if (!(c.sensor.range_min_m < c.sensor.range_max_m)) {
    throw ConfigError(src("sensor.range_max_m"), "sensor.range_max_m",
                      fmt::format("{:g} m; allowed: above sensor.range_min_m ({:g} m)",
                                  c.sensor.range_max_m, c.sensor.range_min_m));
  }
  // The simulated drive and sensor share one plant: neither works alone.
  const bool sim_drive = c.drive.backends.chosen().simulated(),
             sim_sensor = c.sensor.backends.chosen().simulated();
  if (sim_drive != sim_sensor) {
    throw ConfigError(src("sensor.backend"), "sensor.backend",
                      fmt::format("\"{}\" cannot go with drive.backend = \"{}\": the "
                                  "simulated drive and sensor share one plant; allowed: both "
                                  "simulated (\"sim\") or neither",
                                  c.sensor.backend(), c.drive.backend()));
  }
  if (c.lines.backends.chosen().simulated() && !sim_drive) {
    throw ConfigError(src("lines.backend"), "lines.backend",
                      fmt::format("\"{}\" needs the simulated drive; allowed here: a real "
                                  "backend (\"gpiod\", \"none\")",
                                  c.lines.backend()));
  }
  if (c.virtual_clock() && !sim_drive) {
    throw ConfigError(src("run.clock"), "run.clock",
                      "\"virtual\" needs the simulated rig (backend = \"sim\"); real devices "
                      "run in real time");
  }
  check_each(c.drive.backends, c.drive_common(), src);
  check_each(c.lines.backends, hal::LinesCommon{}, src);
}

void check_whole(const ConfigFile& c, const std::map<std::string, std::string>& source_of,
                 ConfigScope scope) {
  const hal::SourceOf src = [&](const std::string& key) {
    const auto it = source_of.find(key);
    return it == source_of.end() ? c.source : it->second;
  };
  const BoardConfig& b = c.board;
  const HostConfig& h = c.host;
  require_valid(b.model, c.source);
  // [move]'s defaults by the board's own rule (hold below the timeout).
  if (const auto breach = firmware::check_move(h.run.move_defaults)) {
    const std::string key = "move." + breach->key;
    throw ConfigError(src(key), key, breach->message);
  }
  model::Parameters plant{b.model.drive, b.plant};
  if (const auto issues = model::validate(plant); !issues.empty()) {
    throw ConfigError(c.source, "plant." + issues.front().name, issues.front().message);
  }
  check_each(b.sensor.backends, b.sensor.common(), src);
  // A sensor-only tool (`piezo sensor read`, rig-sim) uses no drive: how the
  // drive would pair with the sensor, or its limits, are not its business.
  if (scope == ConfigScope::sensor) return;
  check_backends(b, src);
  const auto& lim = b.drive.limits;
  if (lim.V_min >= lim.V_max) {
    throw ConfigError(
        src("drive.V_min"), "drive.V_min",
        fmt::format("{:g} V must be below drive.V_max = {:g} V", lim.V_min, lim.V_max));
  }
  // The board checks its requests by the same rule (a run with nothing to
  // drive is a mistake).
  if (const auto breach =
          firmware::check_drive(h.model.drive, h.run.duration_s, {lim, b.drive.rate_hz})) {
    const std::string key = "drive." + breach->key;
    throw ConfigError(src(key), key, breach->message);
  }
  if (b.sensor.rate_hz > b.drive.rate_hz) {
    throw ConfigError(src("sensor.rate_hz"), "sensor.rate_hz",
                      fmt::format("{:g} Hz exceeds drive.rate_hz = {:g} Hz; allowed: <= {:g}",
                                  b.sensor.rate_hz, b.drive.rate_hz, b.drive.rate_hz));
  }
  // A ramp to 0 V that takes longer than this is no stop.
  constexpr double kLongestRamp_s = 2.0;
  if (b.safety.ramp_down_V_per_s < lim.V_max / kLongestRamp_s) {
    throw ConfigError(
        src("safety.ramp_down_V_per_s"), "safety.ramp_down_V_per_s",
        fmt::format("{:g} V/s takes {:.3g} s to ramp from drive.V_max = {:g} V; "
                    "allowed: >= {:g} V/s (at most {:g} s)",
                    b.safety.ramp_down_V_per_s, lim.V_max / b.safety.ramp_down_V_per_s, lim.V_max,
                    lim.V_max / kLongestRamp_s, kLongestRamp_s));
  }
  if (b.safety.sensor_stale_s <= 1.0 / b.sensor.rate_hz) {
    throw ConfigError(src("safety.sensor_stale_s"), "safety.sensor_stale_s",
                      fmt::format("{:g} s must exceed one sensor period ({:g} s)",
                                  b.safety.sensor_stale_s, 1.0 / b.sensor.rate_hz));
  }
}

/// The files, `--set`, then a command's drive options; checked as a whole.
ConfigFile load(const std::vector<std::string>& paths, const std::vector<std::string>& sets,
               ConfigScope scope, const DriveOptions& options) {
  ConfigFile c;
  // No file: the defaults (a host whose rig is a board with its own config).
  c.source = paths.empty() ? std::string("defaults") : paths.front();
  c.board.source = c.source;
  model::MotorParameters plant_keys = all_nan();
  std::vector<std::string> present;
  // Each file overlays the ones before it (e.g. a rig config, then fitted parameters).
  for (const auto& path : paths) {
    // Read once: the text is parsed and kept as the run's config.
    const std::string text = read_config_file(path);
    const toml::table file = parse_config_text(text, path);
    for (const auto& [k, node] : file) present.emplace_back(k.str());
    if (!c.text.empty()) c.text += "\n# ---- " + path + "\n";
    c.text += text;
    read_tables(file, path, c, plant_keys);
  }
  const std::vector<std::string> required =
      scope == ConfigScope::whole ? kRequiredSections : std::vector<std::string>{"sensor"};
  for (const auto& section : paths.empty() ? std::vector<std::string>{} : required) {
    if (std::find(present.begin(), present.end(), section) == present.end()) {
      throw ConfigError(paths.back(), section,
                        fmt::format("missing section [{}] (required: [{}])", section,
                                    fmt::join(required, "], [")));
    }
  }

  std::map<std::string, std::string> source_of;
  if (!sets.empty()) c.text += "\n# --set overrides\n";
  for (const auto& s : sets) {
    const toml::table t = override_table(s);
    read_tables(t, "--set", c, plant_keys);
    source_of[s.substr(0, s.find('='))] = "--set";
    c.text += "# --set " + s + "\n";
  }
  // The command's own options, as values: the run's config text says so.
  const auto option = [&](const char* key, const char* name, double value, double& into) {
    into = value;
    source_of[key] = name;
    c.text += fmt::format("# {} {}\n", name, value);
  };
  if (options.V0 || options.f || options.duration_s || options.reverse) {
    c.text += "\n# the command's options\n";
  }
  if (options.V0) option("drive.V0", "--V0", *options.V0, c.host.model.drive.V0);
  if (options.f) option("drive.f", "--f", *options.f, c.host.model.drive.f);
  if (options.duration_s) {
    option("run.duration_s", "--duration", *options.duration_s, c.host.run.duration_s);
  }
  if (options.reverse) {
    c.host.model.drive.direction = model::Direction::reverse;
    source_of["drive.direction"] = "--reverse";
    c.text += "# --reverse\n";
  }
  c.board.model.drive = c.host.model.drive;
  c.board.plant = overlay(c.board.model.motor, plant_keys);
  check_whole(c, source_of, scope);
  return c;
}

}  // namespace

ConfigFile load_config_file(const std::string& path, const std::vector<std::string>& sets,
                          ConfigScope scope) {
  return load_config_file(std::vector<std::string>{path}, sets, scope);
}

ConfigFile load_config_file(const std::vector<std::string>& paths,
                          const std::vector<std::string>& sets, ConfigScope scope) {
  return load(paths, sets, scope, {});
}

ConfigFile load_config_file(const std::vector<std::string>& paths,
                          const std::vector<std::string>& sets, const DriveOptions& options) {
  return load(paths, sets, ConfigScope::whole, options);
}

std::string_view name(RunClock c) {
  return kRunClockNames.name(c);
}

model::Parameters load_model_config(const std::string& path) {
  // Every section is read (and so checked), whatever command asks: one
  // reader per section, one meaning per key.
  ConfigFile c;
  model::MotorParameters plant_keys = all_nan();
  read_tables(parse_config_file(path), path, c, plant_keys);
  require_valid(c.host.model, path);
  return c.host.model;
}

KeyDeclarations declared_keys() {
  ConfigFile c;
  model::MotorParameters plant_keys = all_nan();
  KeyDeclarations declarations;
  read_tables(toml::table{}, "defaults", c, plant_keys, &declarations);
  return declarations;
}

void check_drive_hardware(const BoardConfig& c, double hardware_V_min, double hardware_V_max) {
  const auto& lim = c.drive.limits;
  if (lim.V_max > hardware_V_max || lim.V_min < hardware_V_min) {
    throw ConfigError(
        c.source, "drive.V_max",
        fmt::format("[{:g}, {:g}] V exceeds what the drive hardware can produce, "
                    "[{:g}, {:g}] V (DAC full scale x amplifier gain, amplifier rails)",
                    lim.V_min, lim.V_max, hardware_V_min, hardware_V_max));
  }
}

}  // namespace piezo::config
