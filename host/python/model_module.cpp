// piezo_rig._model: the project's C++ model for Python (pybind11). The same
// code as `piezo simulate`, `sensitivity`, `sweep` and `identify`, the same
// checks and messages; the GIL is released while C++ runs, so other Python
// threads (a board client's lease, a notebook's kernel) go on meanwhile.
// piezo_rig/model.py wraps it with docstrings and type hints.

#include <fmt/format.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "config/config_file.hpp"
#include "config/model_config.hpp"
#include "io/fit_io.hpp"
#include "io/parameters_json.hpp"
#include "jobs/interruption.hpp"
#include "jobs/parallel.hpp"
#include "jobs/progress.hpp"
#include "piezo/config/config_error.hpp"
#include "piezo/model/analysis_limits.hpp"
#include "piezo/model/frequency_sweep.hpp"
#include "piezo/model/identify.hpp"
#include "piezo/model/sensitivity.hpp"
#include "piezo/model/simulate.hpp"
#include "piezo/model/travel_targets.hpp"
#include "run/observer_stage.hpp"
#include "studies/global_sensitivity_study.hpp"
#include "studies/oat_study.hpp"
#include "studies/simulate_checks.hpp"

namespace py = pybind11;
using piezo::config::ConfigError;
namespace model = piezo::model;
namespace host = piezo::host;

namespace {

/// KeyboardInterrupt (Ctrl-C, a notebook's interrupt) stops the C++ at its
/// next interruption point: Python's signal flag is read with the
/// interpreter lock held, on the thread that started the work.
void check_python_signals() {
  py::gil_scoped_acquire hold;
  if (PyErr_CheckSignals() != 0) throw py::error_already_set();
}

/// Progress of long work goes to Python's sys.stderr, which a notebook
/// shows under the running cell; show_progress(False) silences it.
std::atomic<bool> progress_shown{true};

void write_to_python_stderr(const std::string& text) {
  if (!progress_shown.load()) return;
  py::gil_scoped_acquire hold;
  const py::object stderr_ = py::module_::import("sys").attr("stderr");
  if (stderr_.is_none()) return;
  stderr_.attr("write")(text);
  stderr_.attr("flush")();
}

/// A numpy array that owns the vector's storage (no copy).
py::array_t<double> to_numpy(std::vector<double>&& values) {
  auto* owned = new std::vector<double>(std::move(values));
  py::capsule free_when_done(owned, [](void* v) { delete static_cast<std::vector<double>*>(v); });
  return py::array_t<double>(static_cast<py::ssize_t>(owned->size()), owned->data(),
                             free_when_done);
}

/// The columns' storage of arrays NumPy has dropped, for the next
/// simulate() to write into: a loop of calls (a study, a benchmark) would
/// otherwise fault in 3 MB of fresh pages at each call, which took about as
/// long as the samples themselves. At most kKeptBytes are kept. Touched
/// with the GIL held only (the arrays' capsules are freed under it).
class ColumnPool {
 public:
  /// A used trajectory to write into: its recorded columns' memory from
  /// the pool where there is some.
  model::Trajectory storage(const model::ColumnSet& kept) {
    model::Trajectory tr;
    const std::array all{&tr.t, &tr.V, &tr.x, &tr.x_dot, &tr.theta, &tr.theta_dot, &tr.z, &tr.F_f};
    for (std::size_t i = 0; i < all.size(); ++i) {
      if (i == 0 || kept[i]) *all[i] = column();
    }
    return tr;
  }
  /// One column's memory (the sample times'), empty if there is none.
  std::vector<double> column() {
    if (free_.empty()) return {};
    std::vector<double> out = std::move(free_.back());
    free_.pop_back();
    bytes_ -= out.capacity() * sizeof(double);
    return out;
  }
  void give(std::vector<double>&& column) {
    const std::size_t bytes = column.capacity() * sizeof(double);
    if (bytes_ + bytes > kKeptBytes) return;
    bytes_ += bytes;
    free_.push_back(std::move(column));
  }
  static ColumnPool& instance() {
    static auto* pool = new ColumnPool;  // never destroyed: arrays may outlive the module
    return *pool;
  }

 private:
  static constexpr std::size_t kKeptBytes = 64u << 20;
  std::vector<std::vector<double>> free_;
  std::size_t bytes_ = 0;
};

/// A numpy array over a column's storage (no copy), which goes back to the
/// pool when the array dies.
py::array_t<double> pooled_numpy(std::vector<double>&& values) {
  auto* owned = new std::vector<double>(std::move(values));
  py::capsule back_to_pool(owned, [](void* v) {
    auto* column = static_cast<std::vector<double>*>(v);
    ColumnPool::instance().give(std::move(*column));
    delete column;
  });
  return py::array_t<double>(static_cast<py::ssize_t>(owned->size()), owned->data(), back_to_pool);
}

std::vector<double> to_vector(
    const py::array_t<double, py::array::c_style | py::array::forcecast>& a,
    const std::string& source, const std::string& key) {
  if (a.ndim() != 1) {
    throw ConfigError(source, key,
                      fmt::format("{} dimensions (allowed: 1, a flat array)", a.ndim()));
  }
  return {a.data(), a.data() + a.size()};
}

/// A Python number as a double; anything else (a string, None, a bool)
/// is a TypeError naming the parameter, not pybind11's cast error.
double number(const py::handle& value, const std::string& where, const std::string& name) {
  if (PyBool_Check(value.ptr()) || !PyNumber_Check(value.ptr()) || PyUnicode_Check(value.ptr())) {
    throw py::type_error(
        fmt::format("{}: {}: expected a number (float or int), got {} {}", where, name,
                    py::str(py::type::of(value).attr("__name__")).cast<std::string>(),
                    py::repr(value).cast<std::string>()));
  }
  return py::float_(py::reinterpret_borrow<py::object>(value)).cast<double>();
}

/// Sets Table 1 parameters by symbol (and the direction), each refused
/// (ValueError) as `--set` refuses it, then the whole set checked (C_dr *
/// e_dr <= 1, ...): a bad value is refused at the call that gives it, and
/// `p` is left as it was.
void set_parameters(model::Parameters& p, const py::dict& values, const std::string& where) {
  model::Parameters next = p;
  for (const auto& [key, value] : values) {
    const auto name = py::str(key).cast<std::string>();
    if (name == "direction") {
      if (!py::isinstance<py::str>(value)) {
        throw py::type_error(fmt::format("{}: direction: expected 'forward' or 'reverse', got {}",
                                         where, py::repr(value).cast<std::string>()));
      }
      next.drive.direction = host::checked_direction(value.cast<std::string>(), "direction");
    } else {
      if (model::find_parameter(name) == nullptr) {
        piezo::config::set_parameter(next, name, 0.0, where);  // refused, naming the known ones
      }
      piezo::config::set_parameter(next, name, number(value, where, name), where);
    }
  }
  piezo::config::require_valid(next, where);
  p = next;
}

/// Parameters as JSON: every symbol and the direction (a round trip keeps both).
std::string parameters_to_json(const model::Parameters& p) {
  auto j = host::to_json(p);
  j["direction"] = std::string(model::name(p.drive.direction));
  return j.dump();
}

model::Parameters parameters_from_json(const std::string& text) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw ConfigError("Parameters.from_json", "text", std::string("not JSON: ") + e.what());
  }
  if (!j.is_object()) throw ConfigError("Parameters.from_json", "text", "not a JSON object");
  std::string direction = "forward";
  if (j.contains("direction")) {
    if (!j["direction"].is_string()) {
      throw ConfigError("Parameters.from_json", "direction", "allowed: forward, reverse");
    }
    direction = j["direction"].get<std::string>();
    j.erase("direction");
  }
  model::Parameters p;
  try {
    p = host::parameters_from_json(j);
  } catch (const std::runtime_error& e) {
    throw ConfigError("Parameters.from_json", "text", e.what());
  }
  p.drive.direction = host::checked_direction(direction, "Parameters.from_json: direction");
  piezo::config::require_valid(p, "Parameters.from_json");
  return p;
}

bool same_parameters(const model::Parameters& a, const model::Parameters& b) {
  for (const auto& s : model::parameter_specs()) {
    if (*model::get_parameter(a, s.name) != *model::get_parameter(b, s.name)) return false;
  }
  return a.drive.direction == b.drive.direction;
}

py::dict stats_dict(const model::IntegrationStats& s) {
  py::dict d;
  d["method"] = std::string(model::to_string(s.integrator));
  d["steps"] = s.steps;
  d["rhs_evaluations"] = s.rhs_evaluations;
  d["mode_switches"] = s.mode_switches;
  d["steps_by_mode"] =
      py::dict(py::arg("series") = s.series_steps, py::arg("linear") = s.linear_steps,
               py::arg("stick") = s.stick_steps);
  return d;
}

py::dict simulate(model::Parameters p, double duration, const std::string& friction_name,
                  const std::string& direction, double dt, double tolerance,
                  const std::string& integrator_name, const std::vector<std::string>& columns) {
  piezo::config::require_valid(p, "Parameters");
  const auto friction = host::checked_friction_model(friction_name, "model");
  if (!direction.empty()) p.drive.direction = host::checked_direction(direction, "direction");
  host::check_duration(duration, "duration");
  if (!(dt > 0.0 && dt <= duration)) {
    throw ConfigError("simulate", "dt", fmt::format("{:g} s (allowed: (0, duration])", dt));
  }
  if (const auto why = model::limits::refused(tolerance, model::limits::kSimulateTolerance)) {
    throw ConfigError("simulate", "tolerance", *why);
  }
  // The trajectory's eight columns for every sample, before any is made:
  // more than the machine's memory is refused naming dt and the size.
  const double samples = std::floor(duration / dt) + 2.0;
  const double bytes = samples * 8.0 * sizeof(double);
  const double memory =
      static_cast<double>(sysconf(_SC_PHYS_PAGES)) * static_cast<double>(sysconf(_SC_PAGESIZE));
  if (bytes > memory) {
    throw ConfigError("simulate", "dt",
                      fmt::format("{:g} s: {:.3g} samples of 8 columns need {:.3g} GiB, more than "
                                  "this machine's {:.3g} GiB (allowed: a dt of at least {:.3g} s)",
                                  dt, samples, bytes / 1073741824.0, memory / 1073741824.0,
                                  duration / (memory / (8.0 * sizeof(double)))));
  }
  const auto integrator = host::checked_integrator(integrator_name, friction, "integrator");
  // t counts the samples and theta gives the end's figures: both always.
  model::ColumnSet kept;
  kept.set(0).set(4);
  for (const auto& name : columns) {
    const auto at = std::find(model::kColumnNames.begin(), model::kColumnNames.end(), name);
    if (at == model::kColumnNames.end()) {
      throw ConfigError(
          "simulate", "columns",
          fmt::format("'{}' (allowed: {})", name, fmt::join(model::kColumnNames, ", ")));
    }
    kept.set(static_cast<std::size_t>(at - model::kColumnNames.begin()));
  }
  model::Trajectory tr = ColumnPool::instance().storage(kept);
  std::vector<double> times = ColumnPool::instance().column();
  {
    py::gil_scoped_release free_python;
    const model::Sawtooth drive(p.drive.V0, p.drive.f, p.drive.rise());
    times = model::uniform_times(duration, dt, std::move(times));
    host::SimulationProgress progress(duration, true, model::differences_from_paper(p));
    tr = model::simulate(p.motor, drive, friction, times,
                         {.tolerance = tolerance,
                          .integrator = integrator,
                          .progress =
                              [&](double t) {
                                host::interruption_point();
                                progress(t);
                              },
                          .columns = kept},
                         std::move(tr));
    progress.finish();
  }
  ColumnPool::instance().give(std::move(times));
  py::dict out;
  out["theta_end_rad"] = tr.theta.back();
  out["mean_velocity_rad_s"] = tr.theta.back() / duration;
  out["integrator"] = stats_dict(tr.stats);
  out["switch_times"] = to_numpy(std::move(tr.switch_times));
  const std::array all{&tr.t, &tr.V, &tr.x, &tr.x_dot, &tr.theta, &tr.theta_dot, &tr.z, &tr.F_f};
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (kept[i])
      out[py::str(std::string(model::kColumnNames[i]))] = pooled_numpy(std::move(*all[i]));
  }
  return out;
}

std::string sensitivity(const model::Parameters& p, const std::string& friction_name) {
  piezo::config::require_valid(p, "Parameters");
  const auto friction = host::checked_friction_model(friction_name, "model");
  py::gil_scoped_release free_python;
  return host::to_json(host::oat_study(p, friction), friction_name).dump();
}

std::string global_study(const model::Parameters& p, const std::string& method,
                         const std::vector<std::string>& params, double range_pct,
                         std::size_t samples, std::uint64_t seed, const std::string& output,
                         double runtime_s, int bootstrap, const std::string& friction_name) {
  piezo::config::require_valid(p, "Parameters");
  host::GlobalStudyOptions o;
  o.method = method;
  o.params = params;
  o.range_pct = range_pct;
  o.samples = samples;
  o.seed = seed;
  o.output = output;
  o.runtime_s = runtime_s;
  o.bootstrap = bootstrap;
  o.model = host::checked_friction_model(friction_name, "model");
  // Errors name the Python call's keyword arguments, not the CLI's flags.
  const std::string at = method + ": ";
  o.names = {
      at + "names",  at + "range_pct", at + (method == "morris" ? "trajectories" : "samples"),
      at + "output", at + "runtime",   at + "bootstrap"};
  py::gil_scoped_release free_python;
  return host::global_study(p, o).dump();
}

py::dict sweep(const model::Parameters& base, const std::string& name,
               const std::vector<double>& values, int periods, const std::string& friction_name) {
  const auto friction = host::checked_friction_model(friction_name, "model");
  if (name != "D" && model::find_parameter(name) == nullptr) {
    throw ConfigError("sweep", "name",
                      name + ": unknown (allowed: a Table 1 symbol (V0, f, mu, ...) or D)");
  }
  if (const auto why = model::limits::refused(periods, model::limits::kSweepPeriods)) {
    throw ConfigError("sweep", "periods", *why);
  }
  for (double v : values) {
    piezo::config::require_valid(model::with_level(base, name, v),
                                 fmt::format("sweep: values: {}={:g}", name, v));
  }
  std::vector<model::StepMetrics> points(values.size());
  {
    py::gil_scoped_release free_python;
    const model::PeriodSettings settings{periods, 2, 200};
    host::parallel_for(
        values.size(),
        [&](std::size_t i) {
          points[i] = model::period_metrics(model::with_level(base, name, values[i]), friction,
                                            settings, host::interruptible());
        },
        host::counted_progress("sweep", "points"));
  }
  std::vector<double> velocity, step, backslip;
  for (const auto& m : points) {
    velocity.push_back(m.mean_velocity_rad_s);
    step.push_back(m.step_rad);
    backslip.push_back(m.backslip_rad);
  }
  py::dict out;
  out["values"] = to_numpy(std::vector<double>(values));
  out["mean_velocity_rad_s"] = to_numpy(std::move(velocity));
  out["step_rad"] = to_numpy(std::move(step));
  out["backslip_rad"] = to_numpy(std::move(backslip));
  return out;
}

py::dict fit_result(model::FitResult&& r, std::size_t samples) {
  py::dict parameters, errors, intervals;
  for (const auto& f : r.fitted) {
    parameters[f.name.c_str()] = f.value;
    errors[f.name.c_str()] = f.standard_error;
    intervals[f.name.c_str()] = py::make_tuple(f.low95, f.high95);
  }
  py::dict out;
  out["parameters"] = parameters;
  out["standard_errors"] = errors;
  out["confidence_95"] = intervals;
  out["rmse_rad"] = r.rmse_rad;
  out["initial_rmse_rad"] = r.initial_rmse_rad;
  out["iterations"] = r.iterations;
  out["converged"] = r.converged;
  out["stop_reason"] = r.stop_reason;
  out["samples"] = samples;
  out["notes"] = r.notes;
  out["fitted"] = r.parameters;
  out["theta_fit"] = to_numpy(std::move(r.theta_fit));
  return out;
}

py::dict identify(const model::Parameters& start, const model::FitData& data,
                  const std::optional<std::vector<std::string>>& free,
                  const std::string& friction_name, int max_iterations) {
  const auto friction = host::checked_friction_model(friction_name, "model");
  if (const auto why = model::limits::refused(max_iterations, model::limits::kFitIterations)) {
    throw ConfigError("identify", "max_iterations", *why);
  }
  piezo::config::require_valid(start, "identify: params");
  const auto names = host::checked_free_parameters(free, friction, "identify", "free");
  if (data.t.size() < names.size() + 2) {
    throw ConfigError("identify", "theta",
                      fmt::format("{} good readings for {} free parameters (allowed: at least "
                                  "{}, two more than the parameters)",
                                  data.t.size(), names.size(), names.size() + 2));
  }
  model::FitResult r;
  {
    py::gil_scoped_release free_python;
    auto settings = host::cli_fit_settings(names, friction, "identify");
    settings.max_iterations = max_iterations;
    r = model::identify(start, data, settings);
  }
  return fit_result(std::move(r), data.t.size());
}

/// A fit to reported travel times (`piezo identify --target`): each target
/// (settings by symbol, angle [rad], time [s]) as the CLI reads it.
py::dict fit_travel_targets(
    const model::Parameters& start,
    const std::vector<std::tuple<std::map<std::string, double>, double, double>>& targets,
    const std::optional<std::vector<std::string>>& free, const std::string& friction_name,
    int max_iterations) {
  const auto friction = host::checked_friction_model(friction_name, "model");
  if (const auto why = model::limits::refused(max_iterations, model::limits::kFitIterations)) {
    throw ConfigError("identify", "max_iterations", *why);
  }
  piezo::config::require_valid(start, "identify: params");
  std::vector<model::TravelTarget> parsed;
  for (std::size_t i = 0; i < targets.size(); ++i) {
    const auto& [settings, angle, time] = targets[i];
    std::string text;
    for (const auto& [name, value] : settings) text += fmt::format("{}={},", name, value);
    // The CLI's reader: one set of checks and words for both.
    parsed.push_back(
        host::parse_travel_target(fmt::format("{}angle={},time={}", text, angle, time)));
  }
  const auto names =
      host::checked_target_free_parameters(free, friction, parsed.size(), "identify", "free");
  if (names.size() > parsed.size()) {
    throw ConfigError("identify", "free",
                      fmt::format("{} targets fix at most {} free parameters; got {}",
                                  parsed.size(), parsed.size(), names.size()));
  }
  model::TargetFitResult r;
  {
    py::gil_scoped_release free_python;
    auto settings = host::cli_target_fit_settings(names, friction, "identify");
    settings.max_iterations = max_iterations;
    r = model::fit_travel_targets(start, parsed, settings);
  }
  py::dict out = fit_result(std::move(r.fit), 0);
  py::list met;
  for (std::size_t i = 0; i < parsed.size(); ++i) {
    py::dict t;
    t["model_time_s"] = r.targets[i].model_time_s;
    t["relative_error"] = r.targets[i].relative_error;
    t["initial_model_time_s"] = r.initial_targets[i].model_time_s;
    met.append(t);
  }
  out["targets"] = met;
  return out;
}

/// The LuGre observer of `piezo run` (host/src/run/observer_stage.hpp) on a
/// recorded drive and angle, as the host runs it beside a live run.
py::dict observe(const model::Parameters& p, const model::FitData& data,
                 const model::ObserverGains& gains, double latency) {
  piezo::config::require_valid(p, "observe: params");
  // The ranges of the config's [observer] keys (docs/configuration.md).
  namespace limits = model::limits;
  for (const auto& [key, value, allowed, unit] :
       {std::tuple{"alpha", gains.alpha, limits::kObserverAlpha, ""},
        std::tuple{"beta", gains.beta, limits::kObserverBeta, ""},
        std::tuple{"gate_rad", gains.gate_rad, limits::kObserverGate_rad, "rad"},
        std::tuple{"latency", latency, limits::kObserverLatency_s, "s"},
        std::tuple{"ramp_time", data.ramp_time, limits::kObserverRampTime_s, "s"}}) {
    if (const auto why = limits::refused(value, allowed, unit)) {
      throw ConfigError("observe", key, *why);
    }
  }
  host::log_schema::ObserverRows rows;
  host::ObserverSummary summary;
  {
    py::gil_scoped_release free_python;
    host::ObserverStage stage(p.motor, gains, data.ramp_time, latency);
    // The stage holds each measurement until the drive is known up to it,
    // so the whole drive first, then the angles, is the live order's result.
    for (std::size_t i = 0; i < data.drive_t.size(); ++i) {
      stage.on_drive(data.drive_t[i], data.drive_V[i], rows);
    }
    for (std::size_t i = 0; i < data.t.size(); ++i) {
      if (std::isfinite(data.theta[i])) stage.on_measurement(data.t[i], data.theta[i], rows);
    }
    stage.finish(rows);
    summary = stage.summary();
  }
  py::dict out;
  out["t"] = to_numpy(std::move(rows.t));
  out["theta_hat"] = to_numpy(std::move(rows.theta_hat));
  out["theta_dot_hat"] = to_numpy(std::move(rows.theta_dot_hat));
  out["x_hat"] = to_numpy(std::move(rows.x_hat));
  out["z_hat"] = to_numpy(std::move(rows.z_hat));
  out["F_hat"] = to_numpy(std::move(rows.F_hat));
  out["residual"] = to_numpy(std::move(rows.residual));
  out["theta_open"] = to_numpy(std::move(rows.theta_open));
  out["summary"] = py::dict(
      py::arg("samples") = summary.samples, py::arg("residual_rms_rad") = summary.residual_rms_rad,
      py::arg("open_loop_rms_rad") = summary.open_loop_rms_rad,
      py::arg("outliers") = summary.outliers, py::arg("restarts") = summary.restarts);
  return out;
}

/// A run as identify reads it: a piezo log, or another tool's HDF5 / MATLAB
/// v7.3 file / CSV with the datasets named.
py::tuple load_run(const std::string& path, const host::LogLayout& layout) {
  host::LoadedRun run = host::load_run_for_fit(path, layout);
  return py::make_tuple(std::move(run.data), run.parameters);
}

void bind_parameters(py::module_& m) {
  auto cls = py::class_<model::Parameters>(
      m, "Parameters", R"(The model's parameters (paper Table 1), SI units, by the paper's symbols:
    drive: V0 [V], f [Hz], C_dr, e_dr, direction ("forward" or "reverse"); D = C_dr*e_dr
    motor: d_e [m/V], M [kg], J [kg m^2], C [N s/m], K [N/m], r [m], mu, F_N [N],
           sigma0 [N/m], sigma1 [N s/m], sigma2 [N s/m]
Parameters(**values) starts from Table 1. A value outside its range raises ValueError
(ParameterError) naming it and the range; parameter_specs() lists them all.
Parameters.from_config(path) reads a TOML config's [drive] and [model].)");
  cls.def(py::init([](const py::kwargs& values) {
            model::Parameters p;
            set_parameters(p, values, "Parameters");
            return p;
          }),
          "Parameters(**values): Table 1, with the values given by symbol.");
  cls.def(
      "replace",
      [](const model::Parameters& p, const py::kwargs& values) {
        model::Parameters next = p;
        set_parameters(next, values, "Parameters.replace");
        return next;
      },
      "A copy with the values given by symbol, checked together (C_dr and e_dr at once, say).");
  cls.def("__eq__", [](const model::Parameters& a, const py::object& b) -> py::object {
    if (!py::isinstance<model::Parameters>(b))
      return py::reinterpret_borrow<py::object>(Py_NotImplemented);
    return py::bool_(same_parameters(a, b.cast<const model::Parameters&>()));
  });
  cls.attr("__hash__") = py::none();  // mutable: equal by value, not hashable
  cls.def(
      "to_dict",
      [](const model::Parameters& p) {
        py::dict d;
        for (const auto& s : model::parameter_specs()) {
          model::Parameters copy = p;
          d[std::string(s.name).c_str()] = s.ref(copy);
        }
        d["direction"] = std::string(model::name(p.drive.direction));
        return d;
      },
      "Every parameter by symbol, and the direction.");
  cls.def("__repr__", [](const model::Parameters& p) {
    std::string text = "Parameters(";
    for (const auto& s : model::parameter_specs()) {
      model::Parameters copy = p;
      text += fmt::format("{}={}, ", s.name, s.ref(copy));
    }
    return text + fmt::format("direction='{}')", model::name(p.drive.direction));
  });
  cls.def("copy", [](const model::Parameters& p) { return p; });
  for (const auto& spec : model::parameter_specs()) {
    const std::string name(spec.name);
    const model::ParameterSpec* s = &spec;
    cls.def_property(
        name.c_str(), [s](model::Parameters& p) { return s->ref(p); },
        [name](model::Parameters& p, const py::object& v) {
          py::dict one;
          one[name.c_str()] = v;
          set_parameters(p, one, "Parameters");
        },
        fmt::format("{} [{}], allowed {} (section [{}])", name, spec.unit, spec.range_text(),
                    spec.section)
            .c_str());
  }
  cls.def_property(
      "direction",
      [](const model::Parameters& p) { return std::string(model::name(p.drive.direction)); },
      [](model::Parameters& p, const py::object& d) {
        py::dict one;
        one["direction"] = d;
        set_parameters(p, one, "Parameters");
      },
      "forward (slow rise, fast fall) or reverse (the mirrored sawtooth)");
  cls.def_property_readonly(
      "D", [](const model::Parameters& p) { return p.drive.D(); },
      "effective rise fraction C_dr * e_dr");
  cls.def(
      "validate", [](const model::Parameters& p) { piezo::config::require_valid(p, "Parameters"); },
      "Raises ValueError naming the first parameter out of its range.");
  cls.def("to_json", &parameters_to_json,
          "Every parameter by symbol and the direction, as JSON (from_json reads it back).");
  cls.def_static("from_json", &parameters_from_json, py::arg("text"),
                 "Parameters from to_json's text (or a log's model_parameters); the direction "
                 "forward when the text has none.");
  cls.def_static("from_config",
                 [](const std::string& path) { return piezo::config::load_model_config(path); });
  // Pickled as the parameters' JSON, the direction included (processes of a pool).
  cls.def(py::pickle(
      [](const model::Parameters& p) { return py::make_tuple(parameters_to_json(p)); },
      [](const py::tuple& state) { return parameters_from_json(state[0].cast<std::string>()); }));
}

}  // namespace

PYBIND11_MODULE(_model, m) {
  m.doc() = "The piezo-rig motor model (C++); use piezo_rig.model.";
  py::register_exception<ConfigError>(m, "ParameterError", PyExc_ValueError);
  host::set_interruption_check(&check_python_signals);
  host::set_progress_sink(&write_to_python_stderr);
  m.def(
      "show_progress", [](bool shown) { progress_shown = shown; }, py::arg("shown") = true,
      "Whether long work (studies, sweeps, fits, simulations of more than a second) "
      "reports its progress on sys.stderr, under the running cell in a notebook; on by default.");
  bind_parameters(m);

  py::class_<model::FitData>(m, "FitData")
      .def(
          py::init([](const py::array_t<double, py::array::c_style | py::array::forcecast>& drive_t,
                      const py::array_t<double, py::array::c_style | py::array::forcecast>& drive_V,
                      const py::array_t<double, py::array::c_style | py::array::forcecast>& t,
                      const py::array_t<double, py::array::c_style | py::array::forcecast>& theta,
                      std::optional<double> ramp_time, const std::string& source) {
            return host::checked_fit_data(
                to_vector(drive_t, source, "drive_t"), to_vector(drive_V, source, "drive_V"),
                to_vector(t, source, "t"), to_vector(theta, source, "theta"), ramp_time, source);
          }),
          py::arg("drive_t"), py::arg("drive_V"), py::arg("t"), py::arg("theta"),
          py::arg("ramp_time") = py::none(), py::arg("source") = "FitData")
      .def_property_readonly(
          "drive_t", [](const model::FitData& d) { return to_numpy(std::vector(d.drive_t)); })
      .def_property_readonly(
          "drive_V", [](const model::FitData& d) { return to_numpy(std::vector(d.drive_V)); })
      .def_property_readonly("t",
                             [](const model::FitData& d) { return to_numpy(std::vector(d.t)); })
      .def_property_readonly("theta",
                             [](const model::FitData& d) { return to_numpy(std::vector(d.theta)); })
      .def_readonly("ramp_time", &model::FitData::ramp_time)
      // Pickled whole, as the arrays it holds (a fit sent back from a worker
      // process carries its data).
      .def(py::pickle(
          [](const model::FitData& d) {
            return py::make_tuple(to_numpy(std::vector(d.drive_t)),
                                  to_numpy(std::vector(d.drive_V)), to_numpy(std::vector(d.t)),
                                  to_numpy(std::vector(d.theta)), d.ramp_time);
          },
          [](const py::tuple& state) {
            const auto column = [&](int i) {
              const auto a =
                  state[static_cast<std::size_t>(i)]
                      .cast<py::array_t<double, py::array::c_style | py::array::forcecast>>();
              return std::vector<double>(a.data(), a.data() + a.size());
            };
            return model::FitData{column(0), column(1), state[4].cast<double>(), column(2),
                                  column(3)};
          }));

  py::class_<host::LogLayout>(m, "LogLayout")
      .def(py::init([](std::string t, std::string V, std::string theta, std::string theta_t,
                       std::string axis) {
             return host::LogLayout{std::move(t), std::move(V), std::move(theta),
                                    std::move(theta_t), std::move(axis)};
           }),
           py::arg("t") = "", py::arg("V") = "", py::arg("theta") = "", py::arg("theta_t") = "",
           py::arg("axis") = "");

  m.def("simulate", &simulate, py::arg("params"), py::arg("duration"), py::arg("model"),
        py::arg("direction"), py::arg("dt"), py::arg("tolerance"), py::arg("integrator"),
        py::arg("columns"));
  m.def("sensitivity", &sensitivity, py::arg("params"), py::arg("model"));
  m.def("global_study", &global_study, py::arg("params"), py::arg("method"), py::arg("names"),
        py::arg("range_pct"), py::arg("samples"), py::arg("seed"), py::arg("output"),
        py::arg("runtime"), py::arg("bootstrap"), py::arg("model"));
  m.def("sweep", &sweep, py::arg("params"), py::arg("name"), py::arg("values"), py::arg("periods"),
        py::arg("model"));
  m.def("identify", &identify, py::arg("params"), py::arg("data"), py::arg("free"),
        py::arg("model"), py::arg("max_iterations"));
  m.def("fit_travel_targets", &fit_travel_targets, py::arg("params"), py::arg("targets"),
        py::arg("free"), py::arg("model"), py::arg("max_iterations"));
  m.def(
      "observe",
      [](const model::Parameters& p,
         const py::array_t<double, py::array::c_style | py::array::forcecast>& drive_t,
         const py::array_t<double, py::array::c_style | py::array::forcecast>& drive_V,
         const py::array_t<double, py::array::c_style | py::array::forcecast>& t,
         const py::array_t<double, py::array::c_style | py::array::forcecast>& theta,
         double ramp_time, double alpha, double beta, double gate_rad, double latency) {
        // As recorded, nothing left out: the live observer saw every record.
        model::FitData data{to_vector(drive_t, "observe", "drive_t"),
                            to_vector(drive_V, "observe", "drive_V"), ramp_time,
                            to_vector(t, "observe", "t"), to_vector(theta, "observe", "theta")};
        host::check_run_arrays(data.drive_t, data.drive_V, data.t, data.theta, "observe");
        return observe(p, data, {alpha, beta, gate_rad}, latency);
      },
      py::arg("params"), py::arg("drive_t"), py::arg("drive_V"), py::arg("t"), py::arg("theta"),
      py::arg("ramp_time"), py::arg("alpha"), py::arg("beta"), py::arg("gate_rad"),
      py::arg("latency"));
  m.def("load_run", &load_run, py::arg("path"), py::arg("layout"));
  // The names the package's checks and docs offer, from the tables the C++
  // reads them with; and the observer's default gains.
  py::dict names;
  const auto listed = [](const auto& values) {
    py::list out;
    for (const auto& v : values) out.append(std::string(v));
    return py::tuple(out);
  };
  names["models"] = listed(model::friction_model_names());
  names["integrators"] = listed(model::integrator_names());
  names["columns"] = listed(model::kColumnNames);
  std::vector<std::string_view> directions;
  for (const auto& [value, name] : model::kDirectionNames.entries()) directions.push_back(name);
  names["directions"] = listed(directions);
  names["outputs"] = listed(host::kStudyOutputs);
  m.attr("NAMES") = names;
  const model::ObserverGains gains;
  m.attr("OBSERVER_GAINS") = py::dict(py::arg("alpha") = gains.alpha, py::arg("beta") = gains.beta,
                                      py::arg("gate_rad") = gains.gate_rad);
  m.def("parameter_specs", [] {
    py::list out;
    for (const auto& s : model::parameter_specs()) {
      out.append(py::dict(py::arg("name") = std::string(s.name),
                          py::arg("section") = std::string(s.section),
                          py::arg("unit") = std::string(s.unit), py::arg("min") = s.min,
                          py::arg("max") = s.max, py::arg("range") = s.range_text()));
    }
    return out;
  });
}
