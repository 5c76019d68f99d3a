#include "rig_config.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <variant>

#include "config_error.hpp"
#include "modbus_config.hpp"
#include "model_config.hpp"
#include "piezo/firmware/request_limits.hpp"
#include "piezo/overload.hpp"
#include "section_reader.hpp"

namespace piezo::config {
namespace {

const std::vector<std::string> kRequiredSections{"drive", "sensor", "run"};

constexpr Range kPositive{0.0, kInf, true, true};
constexpr Range kNonNegative{0.0, kInf, false, true};

void read_drive(SectionReader r, DriveSettings& d, model::Parameters& waveform) {
  r.choice("backend", d.backend, kDriveBackendNames);
  read_waveform(r, waveform);
  r.number("rate_hz", d.rate_hz, {100.0, 100'000.0}, "Hz");
  r.number("V_min", d.limits.V_min, {0.0, 1000.0}, "V");
  r.number("V_max", d.limits.V_max, {0.0, 1000.0, true}, "V");
  r.number("slew_V_per_s", d.limits.slew_V_per_s, kPositive, "V/s");
  r.integer("dac_bits", d.dac.bits, 4, 24);
  r.number("dac_full_scale_V", d.dac.full_scale_V, {0.0, 100.0, true}, "V");
  r.number("stall_at_s", d.dac.stall_at_s, kNonNegative, "s");
  r.number("stall_for_s", d.dac.stall_for_s, {0.0, 3600.0}, "s");
  r.number("amplifier_gain", d.amplifier.gain, {0.0, 1000.0, true});
  r.number("amplifier_V_max", d.amplifier.V_out_max, {0.0, 1000.0, true}, "V");
  r.number("amplifier_slew_V_per_s", d.amplifier.slew_V_per_s, kPositive, "V/s");
  read_modbus_drive(r, d.ao_link, d.ao, d.ao_guard);
  d.ao.amplifier_gain = d.amplifier.gain;
  auto& g = d.gpio_dac;
  r.text("gpio_chip", g.chip);
  r.integer_list("dac_data_offsets", g.data_offsets, 0, 1023);
  r.integer("dac_strobe_offset", g.strobe_offset, -1, 1023);
  r.flag("dac_data_active_low", g.dac.data_active_low);
  r.flag("dac_strobe_active_low", g.dac.strobe_active_low);
  g.dac.bits = static_cast<int>(g.data_offsets.size());
  g.dac.has_strobe = g.strobe_offset >= 0;
  g.dac.full_scale_V = d.dac.full_scale_V;
  g.dac.amplifier_gain = d.amplifier.gain;
  // The simulated DAC updates at the drive rate, on its own clock, and the
  // signal chain interpolates over one update period.
  d.dac.update_period_s = 1.0 / d.rate_hz;
  d.amplifier.ramp_time_s = 1.0 / d.rate_hz;
  r.finish();
}

void read_sensor(SectionReader r, SensorSettings& s) {
  r.choice("backend", s.backend, kSensorBackendNames);
  r.number("rate_hz", s.sim.rate_hz, {1.0, 100'000.0}, "Hz");
  s.link.transport = s.backend == SensorBackend::modbus_rtu
                         ? hal::modbus::LinkSettings::Transport::rtu
                         : hal::modbus::LinkSettings::Transport::tcp;
  read_modbus_sensor(r, s.link, s.map);
  r.number("r2_m", s.r2_m, {0.0, 10.0, true}, "m");
  r.number("range_min_m", s.range_min_m, {-1e3, 1e3}, "m");
  r.number("range_max_m", s.range_max_m, {-1e3, 1e3}, "m");
  // The laser's stand-off from the reflector: a distance, so above 0.
  r.number("target_distance_m", s.sim.offset_m, {0.0, 10.0, true}, "m");
  r.number("noise_m", s.sim.noise_m, {0.0, 1.0}, "m");
  r.number("quantum_m", s.sim.quantum_m, {0.0, 1.0}, "m");
  r.number("latency_s", s.sim.latency_s, {0.0, 1.0}, "s");
  r.number("dropout_probability", s.sim.dropout_probability, {0.0, 1.0});
  r.number("timeout_s", s.sim.timeout_s, {0.0, 10.0, true}, "s");
  r.number("stall_at_s", s.sim.stall_at_s, kNonNegative, "s");
  r.number("stall_for_s", s.sim.stall_for_s, kPositive, "s");
  r.number("freeze_at_s", s.sim.freeze_at_s, kNonNegative, "s");
  r.number("blind_at_s", s.sim.blind_at_s, kNonNegative, "s");
  int seed = static_cast<int>(s.sim.seed);
  r.integer("seed", seed, 0, 1'000'000'000);
  s.sim.seed = static_cast<unsigned>(seed);
  s.sim.r2_m = s.r2_m;
  r.finish();
}

void read_lines(SectionReader r, LinesSettings& l) {
  r.choice("backend", l.backend, kLinesBackendNames);
  r.number("estop_at_s", l.sim.estop_at_s, kNonNegative, "s");
  auto& g = l.gpiod;
  r.text("chip", g.chip);
  r.integer("enable_offset", g.enable_offset, 0, 1023);
  r.integer("sync_offset", g.sync_offset, -1, 1023);
  r.integer("estop_offset", g.estop_offset, -1, 1023);
  r.flag("enable_active_low", g.gpio.enable_active_low);
  r.flag("sync_active_low", g.gpio.sync_active_low);
  r.flag("estop_active_low", g.gpio.estop_active_low);
  g.gpio.has_sync = g.sync_offset >= 0;
  r.finish();
}

void read_run(SectionReader r, RunSettings& run) {
  r.number("duration_s", run.duration_s, {0.0, 1e6, true}, "s");
  r.choice("clock", run.clock, kRunClockNames);
  r.integer("priority", run.priority, 0, 99);
  r.flag("lock_memory", run.lock_memory);
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
  r.number("alpha", o.gains.alpha, {0.0, 1.0});
  r.number("beta", o.gains.beta, {0.0, 1.0});
  r.number("gate_rad", o.gains.gate_rad, {0.0, 10.0, true}, "rad");
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

/// Everything one table (the file, or one --set) says, read over `c`.
/// [plant] keys are collected apart: the plant is [model] overlaid with them.
void read_tables(const toml::table& t, const std::string& source, RigConfig& c,
                 model::MotorParameters& plant_keys) {
  TableReader file(t, source);
  read_drive(file.section("drive"), c.drive, c.model);
  SectionReader model = file.section("model");
  read_motor(model, c.model.motor);
  model.finish();
  SectionReader plant = file.section("plant");
  read_motor(plant, plant_keys);
  plant.number("end_stop_rad", c.plant_end_stop_rad, {-10.0, 10.0}, "rad");
  plant.finish();
  read_sensor(file.section("sensor"), c.sensor);
  read_lines(file.section("lines"), c.lines);
  read_run(file.section("run"), c.run);
  read_move(file.section("move"), c.run.move_defaults);
  read_safety(file.section("safety"), c.safety);
  read_rig_sim(file.section("rig_sim"), c.rig_sim, c.rig_sim_tcp);
  read_observer(file.section("observer"), c.observer);
  read_daemon(file.section("piezod"), c.daemon);
  read_board_address(file.section("rig"), c.board);
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
  const std::string key = assignment.substr(dot + 1, eq - dot - 1);
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

void check_backends(const RigConfig& c, const std::function<std::string(const std::string&)>& src) {
  if (!(c.sensor.range_min_m < c.sensor.range_max_m)) {
    throw ConfigError(src("sensor.range_max_m"), "sensor.range_max_m",
                      fmt::format("{:g} m; allowed: above sensor.range_min_m ({:g} m)",
                                  c.sensor.range_max_m, c.sensor.range_min_m));
  }
  // The simulated drive and sensor share one plant: neither works alone.
  const bool sim_drive = c.drive.backend == DriveBackend::sim,
             sim_sensor = c.sensor.backend == SensorBackend::sim;
  if (sim_drive != sim_sensor) {
    throw ConfigError(src("sensor.backend"), "sensor.backend",
                      fmt::format("\"{}\" cannot go with drive.backend = \"{}\": the "
                                  "simulated drive and sensor share one plant; allowed: both "
                                  "\"sim\" or neither",
                                  name(c.sensor.backend), name(c.drive.backend)));
  }
  if (c.lines.backend == LinesBackend::sim && !sim_drive) {
    throw ConfigError(src("lines.backend"), "lines.backend",
                      "\"sim\" needs the simulated drive; allowed here: \"none\"");
  }
  if (c.virtual_clock() && !sim_drive) {
    throw ConfigError(src("run.clock"), "run.clock",
                      "\"virtual\" needs the simulated rig (backend = \"sim\"); real devices "
                      "run in real time");
  }
  if (c.drive.backend == DriveBackend::gpiod_dac &&
      (c.drive.gpio_dac.data_offsets.empty() || c.drive.gpio_dac.data_offsets.size() > 32)) {
    throw ConfigError(src("drive.dac_data_offsets"), "drive.dac_data_offsets",
                      "gpiod-dac needs 1 to 32 data line offsets, least significant bit first");
  }
  if (c.lines.backend == LinesBackend::gpiod && c.lines.gpiod.enable_offset < 0) {
    throw ConfigError(src("lines.enable_offset"), "lines.enable_offset",
                      "missing: the gpiod lines need the amplifier-enable line offset");
  }
  if (c.sensor.backend == SensorBackend::modbus_rtu && c.sensor.link.device.empty()) {
    throw ConfigError(src("sensor.device"), "sensor.device",
                      "missing: modbus-rtu needs the serial device, e.g. \"/dev/ttyUSB0\"");
  }
}

/// The analog-output module's registers and the guard against a dead link.
void check_analog_output(const RigConfig& c,
                         const std::function<std::string(const std::string&)>& src) {
  const auto& ao = c.drive.ao;
  const double full_scale_counts = ao.counts_per_V * ao.full_scale_V;
  if (full_scale_counts > hal::modbus::ModbusAnalogOutput::kMaxCounts) {
    throw ConfigError(
        src("drive.ao_counts_per_V"), "drive.ao_counts_per_V",
        fmt::format("{:g} counts/V x drive.ao_full_scale_V = {:g} V is {:g} counts, beyond the "
                    "16-bit register's 65535; allowed: ao_counts_per_V <= {:g}",
                    ao.counts_per_V, ao.full_scale_V, full_scale_counts,
                    hal::modbus::ModbusAnalogOutput::kMaxCounts / ao.full_scale_V));
  }
  if (c.drive.backend != DriveBackend::modbus_ao) return;
  const auto& guard = c.drive.ao_guard;
  if (!ao.watchdog_writes.empty() && guard.watchdog_s <= 0.0) {
    throw ConfigError(src("drive.ao_watchdog_s"), "drive.ao_watchdog_s",
                      "missing: the timeout the ao_watchdog_registers set, in seconds; allowed: "
                      "(0, 60]");
  }
  // A module that keeps its output when the link dies cannot be reached by
  // any stop: only its own watchdog or an enable line can end the drive then.
  if (c.lines.backend == LinesBackend::none && ao.watchdog_writes.empty() &&
      !guard.link_loss_acknowledged) {
    throw ConfigError(
        src("drive.ao_watchdog_registers"), "drive.ao_watchdog_registers",
        "missing: with drive.backend = \"modbus-ao\" and lines.backend = \"none\" nothing can "
        "turn the output off when the Modbus link dies; configure the module's communication "
        "watchdog (ao_watchdog_registers, ao_watchdog_values, ao_watchdog_s), wire an enable "
        "line ([lines] backend = \"gpiod\"), or accept the risk with "
        "drive.ao_link_loss_acknowledged = true");
  }
}

void check_whole(const RigConfig& c, const std::map<std::string, std::string>& source_of,
                 ConfigScope scope) {
  auto src = [&](const std::string& key) {
    const auto it = source_of.find(key);
    return it == source_of.end() ? c.source : it->second;
  };
  require_valid(c.model, c.source);
  // [move]'s defaults by the board's own rule (hold below the timeout).
  if (const auto breach = firmware::check_move(c.run.move_defaults)) {
    const std::string key = "move." + breach->key;
    throw ConfigError(src(key), key, breach->message);
  }
  model::Parameters plant{c.model.drive, c.plant};
  if (const auto issues = model::validate(plant); !issues.empty()) {
    throw ConfigError(c.source, "plant." + issues.front().name, issues.front().message);
  }
  // A sensor-only tool (`piezo sensor read`, rig-sim) uses no drive: how the
  // drive would pair with the sensor, or its limits, are not its business.
  if (scope == ConfigScope::sensor) return;
  check_backends(c, src);
  check_analog_output(c, src);
  const auto& lim = c.drive.limits;
  if (lim.V_min >= lim.V_max) {
    throw ConfigError(
        src("drive.V_min"), "drive.V_min",
        fmt::format("{:g} V must be below drive.V_max = {:g} V", lim.V_min, lim.V_max));
  }
  // The board checks its requests by the same rule (a run with nothing to
  // drive is a mistake).
  if (const auto breach =
          firmware::check_drive(c.model.drive, c.run.duration_s, {lim, c.drive.rate_hz})) {
    const std::string key = "drive." + breach->key;
    throw ConfigError(src(key), key, breach->message);
  }
  if (c.sensor.sim.rate_hz > c.drive.rate_hz) {
    throw ConfigError(src("sensor.rate_hz"), "sensor.rate_hz",
                      fmt::format("{:g} Hz exceeds drive.rate_hz = {:g} Hz; allowed: <= {:g}",
                                  c.sensor.sim.rate_hz, c.drive.rate_hz, c.drive.rate_hz));
  }
  // A ramp to 0 V that takes longer than this is no stop.
  constexpr double kLongestRamp_s = 2.0;
  if (c.safety.ramp_down_V_per_s < lim.V_max / kLongestRamp_s) {
    throw ConfigError(
        src("safety.ramp_down_V_per_s"), "safety.ramp_down_V_per_s",
        fmt::format("{:g} V/s takes {:.3g} s to ramp from drive.V_max = {:g} V; "
                    "allowed: >= {:g} V/s (at most {:g} s)",
                    c.safety.ramp_down_V_per_s, lim.V_max / c.safety.ramp_down_V_per_s, lim.V_max,
                    lim.V_max / kLongestRamp_s, kLongestRamp_s));
  }
  const auto& map = c.sensor.map;
  if (map.address + hal::modbus::word_count(map.type) - 1 > 65535) {
    throw ConfigError(src("sensor.address"), "sensor.address",
                      fmt::format("{} with a {}-register value runs past register 65535; "
                                  "allowed: 0..{}",
                                  map.address, hal::modbus::word_count(map.type),
                                  65536 - hal::modbus::word_count(map.type)));
  }
  if (c.safety.sensor_stale_s <= 1.0 / c.sensor.sim.rate_hz) {
    throw ConfigError(src("safety.sensor_stale_s"), "safety.sensor_stale_s",
                      fmt::format("{:g} s must exceed one sensor period ({:g} s)",
                                  c.safety.sensor_stale_s, 1.0 / c.sensor.sim.rate_hz));
  }
}

}  // namespace

RigConfig load_rig_config(const std::string& path, const std::vector<std::string>& sets,
                          ConfigScope scope) {
  return load_rig_config(std::vector<std::string>{path}, sets, scope);
}

RigConfig load_rig_config(const std::vector<std::string>& paths,
                          const std::vector<std::string>& sets, ConfigScope scope) {
  RigConfig c;
  apply_baumer_om30(c.sensor.link, c.sensor.map);
  // No file: the defaults (a host whose rig is a board with its own config).
  c.source = paths.empty() ? std::string("defaults") : paths.front();
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
      scope == ConfigScope::rig ? kRequiredSections : std::vector<std::string>{"sensor"};
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
  c.plant = overlay(c.model.motor, plant_keys);
  check_whole(c, source_of, scope);
  return c;
}

std::string_view name(DriveBackend b) {
  return kDriveBackendNames.name(b);
}
std::string_view name(SensorBackend b) {
  return kSensorBackendNames.name(b);
}
std::string_view name(LinesBackend b) {
  return kLinesBackendNames.name(b);
}
std::string_view name(RunClock c) {
  return kRunClockNames.name(c);
}

model::Parameters load_model_config(const std::string& path) {
  // Every section is read (and so checked), whatever command asks: one
  // reader per section, one meaning per key.
  RigConfig c;
  model::MotorParameters plant_keys = all_nan();
  read_tables(parse_config_file(path), path, c, plant_keys);
  require_valid(c.model, path);
  return c.model;
}

void check_drive_hardware(const RigConfig& c, double hardware_V_min, double hardware_V_max) {
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
