#include "fit_io.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "h5_file.hpp"
#include "log_schema.hpp"
#include "parameters_json.hpp"
#include "piezo/config/config_error.hpp"
#include "run_recovery.hpp"

namespace piezo::host {
namespace {

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

/// Drive samples with strictly increasing times (a run's stop record may repeat a time).
void add_drive(model::FitData& data, const std::vector<double>& t, const std::vector<double>& V) {
  for (std::size_t i = 0; i < std::min(t.size(), V.size()); ++i) {
    if (std::isfinite(t[i]) && std::isfinite(V[i]) &&
        (data.drive_t.empty() || t[i] > data.drive_t.back())) {
      data.drive_t.push_back(t[i]);
      data.drive_V.push_back(V[i]);
    }
  }
}

void add_measurements(model::FitData& data, const std::vector<double>& t,
                      const std::vector<double>& theta) {
  for (std::size_t i = 0; i < std::min(t.size(), theta.size()); ++i) {
    if (std::isfinite(t[i]) && std::isfinite(theta[i]) && t[i] >= 0.0) {
      data.t.push_back(t[i]);
      data.theta.push_back(theta[i]);
    }
  }
}

/// An HDF5 file laid out by another tool: the datasets `layout` names.
LoadedRun load_foreign_h5(const std::string& path, const LogLayout& layout) {
  const H5File file = H5File::open(path);
  const auto need = [&](const std::string& option, const std::string& name) {
    if (name.empty()) {
      throw config::ConfigError(path, option,
                                "missing: name the dataset (e.g. --t /t --V /V --theta /theta)");
    }
    if (!file.exists(name))
      throw config::ConfigError(path, name, "no such dataset (" + option + ")");
    return file.read(name);
  };
  // Columns are paired by index: a pair of different lengths has two time
  // bases, and pairing it would squeeze one into the other's span.
  const auto pair = [&](const std::vector<double>& times, const std::string& times_name,
                        const std::vector<double>& values, const std::string& values_name,
                        const std::string& fix) {
    if (times.size() == values.size()) return;
    throw config::ConfigError(
        path, values_name,
        fmt::format("{} values against {} times in {} (allowed: as many as the times; {})",
                    values.size(), times.size(), times_name, fix));
  };
  LoadedRun run;
  const std::vector<double> t = need("--t", layout.t), V = need("--V", layout.V);
  pair(t, layout.t, V, layout.V, "the drive's times and volts are sampled together");
  const std::vector<double> theta = need("--theta", layout.theta);
  if (layout.theta_t.empty()) {
    pair(t, layout.t, theta, layout.theta,
         "an angle sampled at other times needs its own times: --theta-t DATASET, theta_t= in "
         "Python");
    add_measurements(run.data, t, theta);
  } else {
    const std::vector<double> theta_t = need("--theta-t", layout.theta_t);
    pair(theta_t, layout.theta_t, theta, layout.theta, "the angle and its times pair one to one");
    add_measurements(run.data, theta_t, theta);
  }
  add_drive(run.data, t, V);
  return run;
}

/// An attribute of an axis: its group's, else the log's (a log written
/// before /axes kept every attribute at its root).
std::optional<std::string> axis_attribute(const H5File& log, const std::string& group,
                                          const char* name) {
  if (!group.empty() && log.has_attribute(group, name)) return log.attribute(group, name);
  if (log.has_attribute("/", name)) return log.attribute("/", name);
  return std::nullopt;
}

LoadedRun load_h5(const std::string& path, const std::string& axis) {
  recover_if_needed(path);  // a crashed run: rebuilt from its journal first
  const H5File log = H5File::open(path);
  const std::string group = axis_group_of(log, path, axis);
  using log_schema::DriveRows;
  using log_schema::SensorRows;
  const std::string drive_t_path = group + log_schema::path(&DriveRows::t);
  const std::string drive_V_path = group + log_schema::path(&DriveRows::V);
  const std::string sensor_t_path = group + log_schema::path(&SensorRows::t);
  const std::string theta_path = group + log_schema::path(&SensorRows::theta);
  for (const auto& name : {drive_t_path, drive_V_path, sensor_t_path, theta_path}) {
    if (!log.exists(name)) {
      throw config::ConfigError(path, name,
                                "missing dataset: not a piezo run log; for another tool's file "
                                "name its datasets (--t, --V, --theta, --theta-t)");
    }
  }
  LoadedRun run;
  // The output follows each logged command after the drive's latency.
  std::vector<double> drive_t = log.read(drive_t_path);
  if (log.has_attribute("/", log_schema::kDriveLatency)) {
    const double latency = std::stod(log.attribute("/", log_schema::kDriveLatency));
    for (double& t : drive_t) t += latency;
  }
  add_drive(run.data, drive_t, log.read(drive_V_path));
  add_measurements(run.data, log.read(sensor_t_path), log.read(theta_path));
  // A log without its parameters (written by another program) starts from Table 1.
  if (const auto parameters = axis_attribute(log, group, log_schema::kModelParameters)) {
    try {
      run.parameters = parameters_from_json(nlohmann::json::parse(*parameters));
    } catch (const std::exception& e) {  // found by fuzzing: a damaged attribute
      throw config::ConfigError(
          path, log_schema::kModelParameters,
          std::string("unreadable (") + e.what() + "); pass the parameters with --config");
    }
  }
  return run;
}

LoadedRun load_csv(const std::string& path, const LogLayout& layout) {
  std::ifstream in(path);
  if (!in) throw config::ConfigError(path, "file", "cannot be read");
  std::string header;
  std::getline(in, header);
  std::vector<std::string> names;
  std::stringstream hs(header);
  for (std::string name; std::getline(hs, name, ',');) {
    name.erase(std::remove_if(name.begin(), name.end(), ::isspace), name.end());
    names.push_back(name);
  }
  auto column = [&](const std::string& n) -> std::size_t {
    const auto it = std::find(names.begin(), names.end(), n);
    if (it == names.end())
      throw config::ConfigError(path, n, "missing column (needed: t, V, theta)");
    return static_cast<std::size_t>(it - names.begin());
  };
  const auto name_or = [](const std::string& given, const char* fallback) {
    return given.empty() ? std::string(fallback) : given;
  };
  const std::size_t it = column(name_or(layout.t, "t")), iV = column(name_or(layout.V, "V")),
                    itheta = column(name_or(layout.theta, "theta"));
  std::vector<double> t, V, theta;
  int line_number = 1;
  for (std::string line; std::getline(in, line);) {
    ++line_number;
    if (line.empty()) continue;
    // Every comma starts a cell, a last one after it included: an empty
    // or unreadable cell is NaN (a missing reading, left out as in a log).
    std::vector<double> row;
    for (std::size_t at = 0;;) {
      const std::size_t comma = std::min(line.find(',', at), line.size());
      const std::string cell = line.substr(at, comma - at);
      char* end = nullptr;
      row.push_back(std::strtod(cell.c_str(), &end));
      if (end == cell.c_str()) row.back() = std::nan("");
      if (comma == line.size()) break;
      at = comma + 1;
    }
    if (row.size() < names.size()) {
      throw config::ConfigError(path, "line " + std::to_string(line_number),
                                fmt::format("{} cells, the header names {} columns (empty cells "
                                            "are allowed, missing commas are not)",
                                            row.size(), names.size()));
    }
    t.push_back(row[it]);
    V.push_back(row[iV]);
    theta.push_back(row[itheta]);
  }
  LoadedRun run;
  add_drive(run.data, t, V);
  add_measurements(run.data, t, theta);
  return run;
}

}  // namespace

double median_interval(const std::vector<double>& t) {
  std::vector<double> d;
  for (std::size_t i = 1; i < t.size(); ++i) d.push_back(t[i] - t[i - 1]);
  if (d.empty()) return 0.0;
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  return d[d.size() / 2];
}

void check_run_arrays(const std::vector<double>& drive_t, const std::vector<double>& drive_V,
                      const std::vector<double>& t, const std::vector<double>& theta,
                      const std::string& source) {
  const auto same_length = [&](const char* a, std::size_t na, const char* b, std::size_t nb) {
    if (na != nb) {
      throw config::ConfigError(
          source, b,
          fmt::format("{} values against {} of {} (allowed: one {} per {})", nb, na, a, b, a));
    }
  };
  same_length("drive_t", drive_t.size(), "drive_V", drive_V.size());
  same_length("t", t.size(), "theta", theta.size());
  if (drive_t.size() < 2) {
    throw config::ConfigError(source, "drive_t",
                              fmt::format("{} samples (allowed: two or more)", drive_t.size()));
  }
  for (std::size_t i = 0; i < drive_t.size(); ++i) {
    if (!std::isfinite(drive_t[i]) || !std::isfinite(drive_V[i])) {
      throw config::ConfigError(source, std::isfinite(drive_t[i]) ? "drive_V" : "drive_t",
                                fmt::format("sample {} is {} (allowed: finite numbers)", i,
                                            std::isfinite(drive_t[i]) ? drive_V[i] : drive_t[i]));
    }
    if (i > 0 && drive_t[i] < drive_t[i - 1]) {
      throw config::ConfigError(source, "drive_t",
                                fmt::format("sample {} ({:g} s) is before the one before "
                                            "(allowed: non-decreasing times)",
                                            i, drive_t[i]));
    }
  }
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (!std::isfinite(t[i])) {
      throw config::ConfigError(source, "t",
                                fmt::format("sample {} is {} (allowed: finite times)", i, t[i]));
    }
    if (i > 0 && t[i] < t[i - 1]) {
      throw config::ConfigError(source, "t",
                                fmt::format("sample {} ({:g} s) is before the one before "
                                            "(allowed: non-decreasing times)",
                                            i, t[i]));
    }
    if (std::isinf(theta[i])) {
      throw config::ConfigError(source, "theta",
                                fmt::format("sample {} is {} (allowed: finite angles, or NaN "
                                            "for a failed reading)",
                                            i, theta[i]));
    }
  }
}

model::FitData checked_fit_data(const std::vector<double>& drive_t,
                                const std::vector<double>& drive_V, const std::vector<double>& t,
                                const std::vector<double>& theta, std::optional<double> ramp_time,
                                const std::string& source) {
  check_run_arrays(drive_t, drive_V, t, theta, source);
  model::FitData data;
  add_drive(data, drive_t, drive_V);
  add_measurements(data, t, theta);
  if (data.drive_t.size() < 2) {
    throw config::ConfigError(source, "drive_t",
                              "fewer than two distinct times (allowed: two or more)");
  }
  if (data.t.empty()) {
    throw config::ConfigError(source, "theta",
                              "no reading at t >= 0 (allowed: at least one finite angle)");
  }
  data.ramp_time = ramp_time.value_or(median_interval(data.drive_t));
  if (!(std::isfinite(data.ramp_time) && data.ramp_time > 0.0)) {
    throw config::ConfigError(source, "ramp_time",
                              fmt::format("{:g} s (allowed: > 0 s)", data.ramp_time));
  }
  return data;
}

std::vector<std::string> checked_free_parameters(
    const std::optional<std::vector<std::string>>& free, model::FrictionModel friction,
    const std::string& source, const std::string& key) {
  if (!free) return model::default_free_parameters(friction);
  const std::string model_name(model::to_string(friction));
  if (free->empty()) {
    throw config::ConfigError(
        source, key,
        "no parameter named (allowed: one or more the " + model_name +
            " model uses, e.g. its defaults " +
            fmt::format("{}", fmt::join(model::default_free_parameters(friction), ", ")) + ")");
  }
  for (std::size_t i = 0; i < free->size(); ++i) {
    const std::string& name = (*free)[i];
    if (model::find_parameter(name) == nullptr) {
      std::string allowed;
      for (const auto& s : model::parameter_specs()) {
        if (model::model_uses(friction, s.name))
          allowed += (allowed.empty() ? "" : ", ") + std::string(s.name);
      }
      throw config::ConfigError(source, key,
                                name + ": unknown parameter (allowed: " + allowed + ")");
    }
    if (!model::model_uses(friction, name)) {
      throw config::ConfigError(
          source, key,
          name + ": the " + model_name +
              " model does not use it (no bristles: sigma0, sigma1 and "
              "sigma2 are LuGre's); fit F_N, d_e or other parameters it uses");
    }
    for (std::size_t j = 0; j < i; ++j) {
      if ((*free)[j] == name) throw config::ConfigError(source, key, name + ": named twice");
    }
  }
  return *free;
}

std::string axis_group_of(const H5File& log, const std::string& path, const std::string& axis) {
  const auto attribute = [&](const char* name) {
    return log.has_attribute("/", name) ? log.attribute("/", name) : std::string();
  };
  std::vector<std::string> axes = log_schema::split_axes(attribute(log_schema::kAxes));
  if (axes.empty()) {
    // A log written before /axes: its one axis at the root, named by its
    // `axis` attribute where the board had several.
    const std::string own = attribute(log_schema::kAxis);
    if (!axis.empty() && axis != own) {
      throw config::ConfigError(path, "--axis",
                                fmt::format("\"{}\": the log holds one axis, {}", axis,
                                            own.empty() ? "unnamed (drop --axis)" : own));
    }
    return {};
  }
  // The axis named, or the log's one axis when none is named.
  if (axis.empty() && axes.size() == 1) return log_schema::axis_group(axes, 0);
  const auto it = std::find(axes.begin(), axes.end(), axis);
  if (it != axes.end()) {
    return log_schema::axis_group(axes, static_cast<std::size_t>(it - axes.begin()));
  }
  throw config::ConfigError(
      path, "--axis",
      axis.empty() ? fmt::format("required: the log holds several axes ({})", fmt::join(axes, ", "))
                   : fmt::format("\"{}\" is not an axis of the log (it holds {})", axis,
                                 fmt::join(axes, ", ")));
}

LoadedRun load_run_for_fit(const std::string& path, const LogLayout& layout) {
  const bool hdf5 = ends_with(path, ".h5") || ends_with(path, ".hdf5") || ends_with(path, ".mat");
  LoadedRun run = !hdf5            ? load_csv(path, layout)
                  : layout.given() ? load_foreign_h5(path, layout)
                                   : load_h5(path, layout.axis);
  if (run.data.drive_t.size() < 2)
    throw config::ConfigError(path, "drive", "fewer than two drive samples");
  if (run.data.t.size() < 10)
    throw config::ConfigError(path, "theta", "fewer than ten good angle samples");
  run.data.ramp_time = median_interval(run.data.drive_t);
  return run;
}

void write_parameters_toml(const std::string& path, const model::Parameters& p,
                           const std::string& comment) {
  toml::table drive, motor;
  for (const auto& spec : model::parameter_specs()) {
    const double v = *model::get_parameter(p, spec.name);
    (spec.section == "drive" ? drive : motor).insert(std::string(spec.name), v);
  }
  std::ofstream out(path);
  out << "# " << comment << "\n";
  out << toml::table{{"drive", drive}, {"model", motor}} << "\n";
  if (!out) throw std::runtime_error("cannot write " + path);
}

std::vector<std::string> parse_parameter_list(const std::string& list) {
  std::vector<std::string> names;
  std::stringstream ss(list);
  for (std::string name; std::getline(ss, name, ',');) {
    if (model::find_parameter(name) == nullptr) {
      std::string allowed;
      for (const auto& s : model::parameter_specs())
        allowed += (allowed.empty() ? "" : ", ") + std::string(s.name);
      throw config::ConfigError("--params", name, "unknown parameter (allowed: " + allowed + ")");
    }
    names.push_back(name);
  }
  if (names.empty()) throw config::ConfigError("--params", list, "no parameter named");
  return names;
}

}  // namespace piezo::host

#include <fmt/format.h>

#include "jobs/parallel.hpp"
#include "jobs/progress.hpp"

namespace piezo::host {

model::FitSettings cli_fit_settings(const std::vector<std::string>& free,
                                    model::FrictionModel friction, const std::string& label) {
  model::FitSettings s;
  s.free = free;
  s.model = friction;
  s.for_each = [](std::size_t n, const std::function<void(std::size_t)>& job) {
    parallel_for(n, job, [](std::size_t, std::size_t) {});
  };
  // Inside each simulation too: on the caller's thread the installed check
  // (Python's signals), in parallel_for's workers the caller's stop.
  s.within_simulation = [](double) { interruption_point(); };
  s.progress = [label](int iteration, double rmse) {
    show_progress(
        fmt::format("{}: iteration {}, RMSE {:.3f} urad\n", label, iteration, 1e6 * rmse));
  };
  return s;
}

std::vector<std::string> checked_target_free_parameters(
    const std::optional<std::vector<std::string>>& free, model::FrictionModel friction,
    std::size_t targets, const std::string& source, const std::string& key) {
  if (!free) return checked_free_parameters(free, friction, source, key);
  // Each name's parameter checked as a log fit's; the target after @ here.
  std::vector<std::string> bases;
  for (const auto& name : *free) {
    try {
      bases.push_back(model::split_free_name(name, targets).first);
    } catch (const std::invalid_argument& e) {
      throw config::ConfigError(source, key, e.what());
    }
  }
  // A parameter may be free for several targets ("d_e@1,d_e@2"): each checked once.
  std::sort(bases.begin(), bases.end());
  bases.erase(std::unique(bases.begin(), bases.end()), bases.end());
  (void)checked_free_parameters(bases, friction, source, key);
  for (std::size_t i = 0; i < free->size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if ((*free)[i] == (*free)[j]) {
        throw config::ConfigError(source, key, (*free)[i] + ": named twice");
      }
    }
  }
  return *free;
}

model::FitSettings cli_target_fit_settings(const std::vector<std::string>& free,
                                           model::FrictionModel friction,
                                           const std::string& label) {
  model::FitSettings s = cli_fit_settings(free, friction, label);
  s.progress = [label](int iteration, double rms) {
    show_progress(fmt::format("{}: iteration {}, RMS of ln(model time / target time) {:.4f}\n",
                              label, iteration, rms));
  };
  return s;
}

model::TravelTarget parse_travel_target(const std::string& text) {
  const auto refuse = [&](const std::string& why) {
    return config::ConfigError("--target", text,
                               why + " (e.g. f=20,d_e=0.228e-6,angle=0.010,time=1.36)");
  };
  model::TravelTarget t;
  bool has_angle = false, has_time = false;
  std::size_t begin = 0;
  while (begin <= text.size()) {
    const std::size_t end = std::min(text.find(',', begin), text.size());
    const std::string item = text.substr(begin, end - begin);
    begin = end + 1;
    const std::size_t eq = item.find('=');
    if (eq == std::string::npos) throw refuse("\"" + item + "\" is not KEY=VALUE");
    const std::string key = item.substr(0, eq), value_text = item.substr(eq + 1);
    double value = 0.0;
    try {
      std::size_t used = 0;
      value = std::stod(value_text, &used);
      if (used != value_text.size()) throw std::invalid_argument(value_text);
    } catch (const std::exception&) {
      throw refuse(key + " = \"" + value_text + "\" is not a number");
    }
    if (!std::isfinite(value)) throw refuse(key + " is not finite");
    if (key == "angle") {
      if (value == 0.0) throw refuse("angle: the angle to cover [rad], not 0");
      t.angle_rad = value;
      has_angle = true;
    } else if (key == "time") {
      if (!(value > 0.0)) throw refuse("time: the time it took [s], above 0");
      t.time_s = value;
      has_time = true;
    } else if (const model::ParameterSpec* s = model::find_parameter(key); s == nullptr) {
      throw refuse("\"" + key + "\" is neither angle, time nor a parameter symbol");
    } else if (!s->admits(value)) {
      throw refuse(fmt::format("{} = {:g}; allowed: {}", key, value, s->range_text()));
    } else {
      t.settings.emplace_back(key, value);
    }
  }
  if (!has_angle || !has_time) throw refuse("needs angle=RAD and time=S");
  return t;
}

}  // namespace piezo::host
