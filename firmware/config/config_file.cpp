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
#include "sections.hpp"

namespace piezo::config {
namespace {

const std::vector<std::string> kRequiredSections{"drive", "sensor", "run"};

// Each owner's section readers (sections.hpp).
using sections::Backends_read, sections::read_drive, sections::read_sensor, sections::read_lines,
    sections::read_safety, sections::read_daemon, sections::read_run, sections::read_move,
    sections::read_observer, sections::read_board_address, sections::read_rig_sim,
    sections::read_plant;

/// Everything one table (the file, or one --set) says, read over `c`: each
/// section into the part of the process that reads it, the axis's sections
/// into the board's first axis. [plant] keys are collected apart: the plant
/// is [model] overlaid with them. [axes] is read by read_axis_tables.
void read_tables(const toml::table& t, const std::string& source, ConfigFile& c,
                 model::MotorParameters& plant_keys, KeyDeclarations* declarations = nullptr,
                 Backends_read which = Backends_read::every) {
  TableReader file(t, source, declarations);
  BoardConfig& board = c.board;
  AxisConfig& axis = board.axis();
  HostConfig& host = c.host;
  read_drive(file.section("drive"), axis.drive, axis.model, which, &board.drive_rate_hz);
  SectionReader model = file.section("model");
  read_motor(model, axis.model.motor);
  model.finish();
  // The waveform and the model are the board's defaults and what the host's
  // run asks for: one file says both.
  host.model = axis.model;
  read_plant(file.section("plant"), plant_keys, axis);
  read_sensor(file.section("sensor"), axis.sensor, which, &board.sensor_rate_hz);
  read_lines(file.section("lines"), board.lines, which);
  read_run(file.section("run"), host.run, board.run);
  read_move(file.section("move"), host.run.move_defaults);
  SectionReader safety = file.section("safety");
  read_safety(safety, axis.safety);
  safety.flag("fault_stops_all", board.fault_stops_all);
  safety.finish();
  read_rig_sim(file.section("rig_sim"), c.rig_sim.faults, c.rig_sim.tcp);
  read_observer(file.section("observer"), host.observer);
  read_daemon(file.section("piezod"), board.daemon);
  read_board_address(file.section("rig"), host.board);
  (void)file.section("axes");  // each axis's own sections: read_axis_tables
  file.finish();
}

/// [axes.NAME]'s own sections, read over the file's for that axis (the
/// board's first in `c`): the sections an axis has, under its name.
void read_axis_tables(const toml::table& t, const std::string& axis, const std::string& source,
                      AxisConfig& a, model::MotorParameters& plant_keys,
                      KeyDeclarations* declarations = nullptr,
                      Backends_read which = Backends_read::every) {
  TableReader own(t, source, declarations, "axes." + axis);
  read_drive(own.section("drive"), a.drive, a.model, which, nullptr);
  SectionReader model = own.section("model");
  read_motor(model, a.model.motor);
  model.finish();
  read_plant(own.section("plant"), plant_keys, a);
  read_sensor(own.section("sensor"), a.sensor, which, nullptr);
  SectionReader safety = own.section("safety");
  read_safety(safety, a.safety);
  safety.finish();
  own.finish();
}

/// "SECTION.KEY=VALUE" as a one-key TOML table; VALUE is read as TOML
/// (numbers, true/false, "strings"), and a bare word as a string.
toml::table override_table(const std::string& assignment) {
  // A --set line has no comments: ASCII throughout (a file's '#' rule does
  // not apply; the TOML reader must never see bytes it cannot take).
  for (const char c : assignment) {
    if (const auto byte = static_cast<unsigned char>(c); byte >= 0x80 || byte < 0x20) {
      throw ConfigError("--set", "--set",
                        "a non-ASCII or control character (allowed: printable ASCII, e.g. "
                        "drive.V0=70)");
    }
  }
  const auto eq = assignment.find('=');
  const auto dot = assignment.find('.');
  if (eq == std::string::npos || dot == std::string::npos || dot > eq) {
    throw ConfigError("--set", assignment, "expected SECTION.KEY=VALUE, e.g. drive.V0=70");
  }
  // SECTION.KEY, SECTION.BACKEND.KEY, or axes.NAME.SECTION.KEY...: each
  // dot a table.
  std::vector<std::string> path;
  for (std::string::size_type begin = 0;;) {
    const auto next = assignment.find('.', begin);
    if (next == std::string::npos || next > eq) {
      path.push_back(assignment.substr(begin, eq - begin));
      break;
    }
    path.push_back(assignment.substr(begin, next - begin));
    begin = next + 1;
  }
  const std::string value = assignment.substr(eq + 1);
  toml::table parsed;
  try {
    parsed = toml::parse("v = " + value);
  } catch (const toml::parse_error&) {
    parsed = toml::table{{"v", value}};
  }
  toml::table inner;
  inner.insert(path.back(), *parsed.get("v"));
  for (auto level = path.rbegin() + 1; level != path.rend(); ++level) {
    inner = toml::table{{*level, inner}};
  }
  return inner;
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

/// An axis's keys as an error names them: its own ([axes.NAME.drive] V_max
/// is "axes.NAME.drive.V_max"), or the file's section it took them from,
/// with the axis's name when the board has several.
struct KeyNamer {
  std::string axis;                     ///< empty: the board's one axis, from the file's sections
  std::vector<const toml::table*> own;  ///< its [axes.NAME] tables, in reading order

  [[nodiscard]] std::string operator()(const std::string& key) const {
    if (axis.empty()) return key;
    for (const toml::table* t : own)
      if (t->at_path(key)) return "axes." + axis + "." + key;
    return key + " (axis " + axis + ")";
  }
};

void check_backends(const BoardConfig& b, const AxisConfig& a, const KeyNamer& named,
                    const hal::SourceOf& src) {
  const auto fail = [&](const std::string& key, const std::string& message) {
    const std::string name = named(key);
    throw ConfigError(src(name), name, message);
  };
  if (!(a.sensor.range_min_m < a.sensor.range_max_m)) {
    fail("sensor.range_max_m", fmt::format("{:g} m; allowed: above sensor.range_min_m ({:g} m)",
                                           a.sensor.range_max_m, a.sensor.range_min_m));
  }
  // The simulated drive and sensor share one plant: neither works alone.
  const bool sim_drive = a.drive.backends.chosen().simulated(),
             sim_sensor = a.sensor.backends.chosen().simulated();
  if (sim_drive != sim_sensor) {
    fail("sensor.backend", fmt::format("\"{}\" cannot go with drive.backend = \"{}\": the "
                                       "simulated drive and sensor share one plant; allowed: both "
                                       "simulated (\"sim\") or neither",
                                       a.sensor.backend(), a.drive.backend()));
  }
  if (b.lines.backends.chosen().simulated() && !sim_drive) {
    throw ConfigError(src("lines.backend"), "lines.backend",
                      fmt::format("\"{}\" needs the simulated drive; allowed here: a real "
                                  "backend (\"gpiod\", \"none\")",
                                  b.lines.backend()));
  }
  if (b.virtual_clock() && !sim_drive) {
    throw ConfigError(src("run.clock"), "run.clock",
                      "\"virtual\" needs the simulated rig (backend = \"sim\"); real devices "
                      "run in real time");
  }
  check_each(a.drive.backends,
             hal::DriveCommon{b.drive_rate_hz, a.drive.amplifier_gain, b.lines.backend() != "none"},
             src);
  check_each(b.lines.backends, hal::LinesCommon{}, src);
}

/// One axis's config as a whole (the board's first, in an axis's reading).
void check_whole(const ConfigFile& c, const KeyNamer& named,
                 const std::map<std::string, std::string>& source_of, ConfigScope scope) {
  const hal::SourceOf src = [&](const std::string& key) {
    const auto it = source_of.find(key);
    return it == source_of.end() ? c.source : it->second;
  };
  const auto fail = [&](const std::string& key, const std::string& message) {
    const std::string name = named(key);
    throw ConfigError(src(name), name, message);
  };
  const BoardConfig& b = c.board;
  const AxisConfig& a = b.axis();
  const HostConfig& h = c.host;
  require_valid(a.model, c.source);
  // [move]'s defaults by the board's own rule (hold below the timeout).
  if (const auto breach = firmware::check_move(h.run.move_defaults)) {
    const std::string key = "move." + breach->key;
    throw ConfigError(src(key), key, breach->message);
  }
  model::Parameters plant{a.model.drive, a.plant};
  if (const auto issues = model::validate(plant); !issues.empty()) {
    fail("plant." + issues.front().name, issues.front().message);
  }
  check_each(a.sensor.backends, b.sensor_common(), src);
  // A sensor-only tool (`piezo sensor read`, rig-sim) uses no drive: how the
  // drive would pair with the sensor, or its limits, are not its business.
  if (scope == ConfigScope::sensor) return;
  check_backends(b, a, named, src);
  const auto& lim = a.drive.limits;
  if (lim.V_min >= lim.V_max) {
    fail("drive.V_min",
         fmt::format("{:g} V must be below drive.V_max = {:g} V", lim.V_min, lim.V_max));
  }
  // The board checks its requests by the same rule (a run with nothing to
  // drive is a mistake).
  if (const auto breach =
          firmware::check_drive(a.model.drive, h.run.duration_s, {lim, b.drive_rate_hz})) {
    fail("drive." + breach->key, breach->message);
  }
  if (b.sensor_rate_hz > b.drive_rate_hz) {
    throw ConfigError(src("sensor.rate_hz"), "sensor.rate_hz",
                      fmt::format("{:g} Hz exceeds drive.rate_hz = {:g} Hz; allowed: <= {:g}",
                                  b.sensor_rate_hz, b.drive_rate_hz, b.drive_rate_hz));
  }
  // A ramp to 0 V that takes longer than this is no stop.
  constexpr double kLongestRamp_s = 2.0;
  if (a.safety.ramp_down_V_per_s < lim.V_max / kLongestRamp_s) {
    fail("safety.ramp_down_V_per_s",
         fmt::format("{:g} V/s takes {:.3g} s to ramp from drive.V_max = {:g} V; "
                     "allowed: >= {:g} V/s (at most {:g} s)",
                     a.safety.ramp_down_V_per_s, lim.V_max / a.safety.ramp_down_V_per_s, lim.V_max,
                     lim.V_max / kLongestRamp_s, kLongestRamp_s));
  }
  if (a.safety.sensor_stale_s <= 1.0 / b.sensor_rate_hz) {
    fail("safety.sensor_stale_s", fmt::format("{:g} s must exceed one sensor period ({:g} s)",
                                              a.safety.sensor_stale_s, 1.0 / b.sensor_rate_hz));
  }
}

/// What holds between the axes: no device resource taken twice.
void check_axes(const BoardConfig& b, const std::vector<KeyNamer>& named,
                const std::string& source) {
  // Each chosen backend's resources, against every earlier axis's.
  struct Taken {
    std::string key;
    std::string resource;
  };
  std::vector<Taken> taken;
  for (std::size_t i = 0; i < b.axes.size(); ++i) {
    const AxisConfig& a = b.axes[i];
    std::vector<hal::Claim> claims = a.drive.backends.chosen().claims();
    for (hal::Claim& claim : a.sensor.backends.chosen().claims())
      claims.push_back(std::move(claim));
    for (const hal::Claim& claim : claims) {
      const std::string key = named[i](claim.key);
      for (const Taken& t : taken) {
        if (t.resource == claim.resource) {
          throw ConfigError(source, key,
                            fmt::format("{} is also {}'s; allowed: a resource no other axis "
                                        "takes",
                                        claim.resource, t.key));
        }
      }
      taken.push_back({key, claim.resource});
    }
  }
}

/// A file, or one --set: parsed once, read once for each axis.
struct Layer {
  toml::table table;
  std::string source;
};

/// The axes the layers declare ([axes.NAME]), in the order they name them.
std::vector<std::string> axis_names(const std::vector<Layer>& layers) {
  std::vector<std::string> names;
  for (const Layer& layer : layers) {
    const toml::table* axes = layer.table["axes"].as_table();
    if (axes == nullptr) continue;
    // A table's keys come sorted: the file's order is where each begins.
    std::vector<std::pair<toml::source_position, std::string>> in_file_order;
    for (const auto& [k, node] : *axes) in_file_order.emplace_back(k.source().begin, k.str());
    std::sort(in_file_order.begin(), in_file_order.end(), [](const auto& a, const auto& b) {
      return std::pair{a.first.line, a.first.column} < std::pair{b.first.line, b.first.column};
    });
    for (const auto& [position, name] : in_file_order) {
      const toml::node& node = *axes->get(name);
      const bool plain = !name.empty() && std::all_of(name.begin(), name.end(), [](char ch) {
        return std::isalnum(static_cast<unsigned char>(ch)) != 0 || ch == '_' || ch == '-';
      });
      if (!plain) {
        throw ConfigError(layer.source, "axes." + name,
                          "an axis name is letters, digits, '_' or '-' (command lines, the "
                          "protocol and the log's groups carry it)");
      }
      if (!node.is_table()) {
        throw ConfigError(layer.source, "axes." + name,
                          "must be a table of the axis's sections ([axes." + name +
                              ".drive], [axes." + name + ".sensor], ...)");
      }
      if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
    }
  }
  return names;
}

/// The files, `--set`, then a command's drive options; each axis read over
/// the file's sections and checked as a whole, then the axes together.
ConfigFile load(const std::vector<std::string>& paths, const std::vector<std::string>& sets,
                ConfigScope scope, const DriveOptions& options) {
  // No file: the defaults (a host whose rig is a board with its own config).
  const std::string source = paths.empty() ? std::string("defaults") : paths.front();
  std::string text;
  std::vector<Layer> layers;
  std::vector<std::string> present;
  // Each file overlays the ones before it (e.g. a rig config, then fitted parameters).
  for (const auto& path : paths) {
    // Read once: the text is parsed and kept as the run's config.
    const std::string file_text = read_config_file(path);
    layers.push_back({parse_config_text(file_text, path), path});
    for (const auto& [k, node] : layers.back().table) present.emplace_back(k.str());
    if (!text.empty()) text += "\n# ---- " + path + "\n";
    text += file_text;
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
  if (!sets.empty()) text += "\n# --set overrides\n";
  for (const auto& s : sets) {
    layers.push_back({override_table(s), "--set"});
    source_of[s.substr(0, s.find('='))] = "--set";
    text += "# --set " + s + "\n";
  }
  // The command's own options, as values: the run's config text says so.
  const auto option = [&](const char* key, const char* name, double value) {
    source_of[key] = name;
    text += fmt::format("# {} {}\n", name, value);
  };
  if (options.V0 || options.f || options.duration_s || options.reverse) {
    text += "\n# the command's options\n";
  }
  if (options.V0) option("drive.V0", "--V0", *options.V0);
  if (options.f) option("drive.f", "--f", *options.f);
  if (options.duration_s) option("run.duration_s", "--duration", *options.duration_s);
  if (options.reverse) {
    source_of["drive.direction"] = "--reverse";
    text += "# --reverse\n";
  }
  const auto apply_options = [&](model::DriveParameters& drive) {
    if (options.V0) drive.V0 = *options.V0;
    if (options.f) drive.f = *options.f;
    if (options.reverse) drive.direction = model::Direction::reverse;
  };

  // One reading per axis: the layers, then the axis's own tables over them.
  const auto read_axis = [&](const std::string& name, KeyNamer& named) {
    ConfigFile c;
    c.source = c.board.source = source;
    c.text = text;
    model::MotorParameters plant_keys = all_nan();
    for (const Layer& layer : layers) read_tables(layer.table, layer.source, c, plant_keys);
    AxisConfig& axis = c.board.axis();
    if (!name.empty()) {
      named.axis = axis.name = name;
      for (const Layer& layer : layers) {
        if (const toml::table* own = layer.table["axes"][name].as_table()) {
          read_axis_tables(layer.table, name, layer.source, axis, plant_keys);
          named.own.push_back(own);
        }
      }
    }
    apply_options(c.host.model.drive);
    apply_options(axis.model.drive);
    if (options.duration_s) c.host.run.duration_s = *options.duration_s;
    axis.plant = overlay(axis.model.motor, plant_keys);
    check_whole(c, named, source_of, scope);
    return c;
  };
  const std::vector<std::string> names = axis_names(layers);
  std::vector<KeyNamer> named(std::max<std::size_t>(1, names.size()));
  ConfigFile c = read_axis(names.empty() ? std::string() : names.front(), named.front());
  for (std::size_t i = 1; i < names.size(); ++i) {
    c.board.axes.push_back(std::move(read_axis(names[i], named[i]).board.axis()));
  }
  if (scope == ConfigScope::whole) check_axes(c.board, named, source);
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

const AxisConfig* BoardConfig::find_axis(std::string_view name) const {
  for (const AxisConfig& a : axes)
    if (a.name == name) return &a;
  return nullptr;
}

std::size_t BoardConfig::axis_index(std::string_view name, const std::string& where) const {
  std::string names;
  for (std::size_t i = 0; i < axes.size(); ++i) {
    if (axes[i].name == name || (name.empty() && axes.size() == 1)) return i;
    names += (names.empty() ? "" : ", ") + axes[i].name;
  }
  throw ConfigError(
      where, "axis",
      name.empty() ? fmt::format("required: {} has several axes ({})", source, names)
                   : fmt::format("\"{}\" is not an axis of {} (allowed: {})", name, source, names));
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

KeyDeclarations effective_keys(const ConfigFile& c) {
  // The readers over an empty table leave every value as it is and declare
  // it: the board's and the host's keys with the first axis's sections as
  // the base, then every axis's own under [axes.NAME].
  KeyDeclarations out;
  ConfigFile base = c;
  base.board.axes.resize(1);
  model::MotorParameters plant = base.board.axis().plant;
  read_tables(toml::table{}, "effective", base, plant, &out, Backends_read::chosen);
  for (const AxisConfig& a : c.board.axes) {
    AxisConfig own = a;
    model::MotorParameters own_plant = a.plant;
    read_axis_tables(toml::table{}, a.name, "effective", own, own_plant, &out,
                     Backends_read::chosen);
  }
  return out;
}

KeyDeclarations declared_keys() {
  ConfigFile c;
  model::MotorParameters plant_keys = all_nan();
  KeyDeclarations declarations;
  read_tables(toml::table{}, "defaults", c, plant_keys, &declarations);
  return declarations;
}

void check_drive_hardware(const BoardConfig& c, std::size_t axis, double hardware_V_min,
                          double hardware_V_max) {
  const auto& lim = c.axis(axis).drive.limits;
  if (lim.V_max > hardware_V_max || lim.V_min < hardware_V_min) {
    throw ConfigError(
        c.source, c.axes.size() > 1 ? "axes." + c.axis(axis).name + ".drive.V_max" : "drive.V_max",
        fmt::format("[{:g}, {:g}] V exceeds what the drive hardware can produce, "
                    "[{:g}, {:g}] V (DAC full scale x amplifier gain, amplifier rails)",
                    lim.V_min, lim.V_max, hardware_V_min, hardware_V_max));
  }
}

}  // namespace piezo::config
