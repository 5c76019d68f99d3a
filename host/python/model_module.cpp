// piezo_rig._model: the project's C++ model for Python (pybind11). The same
// code as `piezo simulate`, `sensitivity`, `sweep` and `identify`, the same
// checks and messages; the GIL is released while C++ runs, so other Python
// threads (a board client's lease, a notebook's kernel) go on meanwhile.
// piezo_rig/model.py wraps it with docstrings and type hints.

#include <fmt/format.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <atomic>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "config_error.hpp"
#include "fit_io.hpp"
#include "global_sensitivity_study.hpp"
#include "interruption.hpp"
#include "model_config.hpp"
#include "oat_study.hpp"
#include "observer_stage.hpp"
#include "parallel.hpp"
#include "parameters_json.hpp"
#include "piezo/model/frequency_sweep.hpp"
#include "piezo/model/identify.hpp"
#include "piezo/model/sensitivity.hpp"
#include "piezo/model/simulate.hpp"
#include "progress.hpp"
#include "rig_config.hpp"
#include "simulate_checks.hpp"

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

std::vector<double> to_vector(
    const py::array_t<double, py::array::c_style | py::array::forcecast>& a,
    const std::string& key) {
  if (a.ndim() != 1) throw ConfigError(key, fmt::format("{} dimensions", a.ndim()), "allowed: 1");
  return {a.data(), a.data() + a.size()};
}

/// Sets one Table 1 parameter, refused (ValueError) as `--set` refuses it.
void set_parameter(model::Parameters& p, const std::string& name, double value) {
  piezo::config::set_parameter(p, name, value, "Parameters");
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
                  const std::string& integrator_name) {
  piezo::config::require_valid(p, "Parameters");
  const auto friction = host::checked_friction_model(friction_name, "model");
  if (!direction.empty()) p.drive.direction = host::checked_direction(direction, "direction");
  host::check_duration(duration, "duration");
  if (!(dt > 0.0)) throw ConfigError("dt", fmt::format("{:g} s", dt), "allowed: > 0 s");
  if (!(tolerance >= 1e-14 && tolerance <= 1e-2)) {
    throw ConfigError("tolerance", fmt::format("{:g}", tolerance), "allowed: [1e-14, 1e-2]");
  }
  const auto integrator = host::checked_integrator(integrator_name, friction, "integrator");
  model::Trajectory tr;
  {
    py::gil_scoped_release free_python;
    const model::Sawtooth drive(p.drive.V0, p.drive.f, p.drive.rise());
    const auto times = model::uniform_times(duration, dt);
    host::SimulationProgress progress(duration, true);
    tr = model::simulate(
        p.motor, drive, friction, times,
        {.tolerance = tolerance, .integrator = integrator, .progress = [&](double t) {
           host::interruption_point();
           progress(t);
         }});
    progress.finish();
  }
  py::dict out;
  out["theta_end_rad"] = tr.theta.back();
  out["mean_velocity_rad_s"] = tr.theta.back() / duration;
  out["integrator"] = stats_dict(tr.stats);
  out["switch_times"] = to_numpy(std::move(tr.switch_times));
  out["t"] = to_numpy(std::move(tr.t));
  out["V"] = to_numpy(std::move(tr.V));
  out["x"] = to_numpy(std::move(tr.x));
  out["x_dot"] = to_numpy(std::move(tr.x_dot));
  out["theta"] = to_numpy(std::move(tr.theta));
  out["theta_dot"] = to_numpy(std::move(tr.theta_dot));
  out["z"] = to_numpy(std::move(tr.z));
  out["F_f"] = to_numpy(std::move(tr.F_f));
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
  py::gil_scoped_release free_python;
  return host::global_study(p, o).dump();
}

py::dict sweep(const model::Parameters& base, const std::string& name,
               const std::vector<double>& values, int periods, const std::string& friction_name) {
  const auto friction = host::checked_friction_model(friction_name, "model");
  if (name != "D" && model::find_parameter(name) == nullptr) {
    throw ConfigError("param", name, "allowed: a Table 1 symbol (V0, f, mu, ...) or D");
  }
  if (periods < 3 || periods > 100000) {
    throw ConfigError("periods", std::to_string(periods), "allowed: [3, 100000]");
  }
  for (double v : values) {
    piezo::config::require_valid(model::with_level(base, name, v), fmt::format("{}={:g}", name, v));
  }
  std::vector<model::StepMetrics> points(values.size());
  {
    py::gil_scoped_release free_python;
    const model::PeriodSettings settings{periods, 2, 200};
    host::parallel_for(
        values.size(),
        [&](std::size_t i) {
          points[i] =
              model::period_metrics(model::with_level(base, name, values[i]), friction, settings);
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
  out["samples"] = samples;
  out["notes"] = r.notes;
  out["fitted"] = r.parameters;
  out["theta_fit"] = to_numpy(std::move(r.theta_fit));
  return out;
}

py::dict identify(const model::Parameters& start, const model::FitData& data,
                  const std::vector<std::string>& free, const std::string& friction_name,
                  int max_iterations) {
  const auto friction = host::checked_friction_model(friction_name, "model");
  if (max_iterations < 1) {
    throw ConfigError("max_iterations", std::to_string(max_iterations), "allowed: >= 1");
  }
  model::FitResult r;
  {
    py::gil_scoped_release free_python;
    auto settings = host::cli_fit_settings(free, friction, "identify");
    settings.max_iterations = max_iterations;
    r = model::identify(start, data, settings);
  }
  return fit_result(std::move(r), data.t.size());
}

/// The LuGre observer of `piezo run` (host/src/run/observer_stage.hpp) on a
/// recorded drive and angle, as the host runs it beside a live run.
py::dict observe(const model::Parameters& p, const model::FitData& data,
                 const model::ObserverGains& gains, double latency) {
  piezo::config::require_valid(p, "Parameters");
  // The ranges of the config's [observer] keys (docs/configuration.md).
  if (!(gains.alpha >= 0.0 && gains.alpha <= 1.0)) {
    throw ConfigError("observe", "alpha", fmt::format("{:g}; allowed: [0, 1]", gains.alpha));
  }
  if (!(gains.beta >= 0.0 && gains.beta <= 1.0)) {
    throw ConfigError("observe", "beta", fmt::format("{:g}; allowed: [0, 1]", gains.beta));
  }
  if (!(gains.gate_rad > 0.0 && gains.gate_rad <= 10.0)) {
    throw ConfigError("observe", "gate_rad",
                      fmt::format("{:g}; allowed: (0, 10] rad", gains.gate_rad));
  }
  if (!(latency >= 0.0 && data.ramp_time > 0.0)) {
    throw ConfigError("observe", "latency", "allowed: latency >= 0 s, ramp_time > 0 s");
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
            for (const auto& [key, value] : values) {
              const auto name = key.cast<std::string>();
              if (name == "direction") {
                p.drive.direction = host::checked_direction(value.cast<std::string>(), "direction");
              } else {
                set_parameter(p, name, value.cast<double>());
              }
            }
            return p;
          }),
          "Parameters(**values): Table 1, with the values given by symbol.");
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
        [name](model::Parameters& p, double v) { set_parameter(p, name, v); },
        fmt::format("{} [{}], allowed {} (section [{}])", name, spec.unit, spec.range_text(),
                    spec.section)
            .c_str());
  }
  cls.def_property(
      "direction",
      [](const model::Parameters& p) { return std::string(model::name(p.drive.direction)); },
      [](model::Parameters& p, const std::string& d) {
        p.drive.direction = host::checked_direction(d, "direction");
      },
      "forward (slow rise, fast fall) or reverse (the mirrored sawtooth)");
  cls.def_property_readonly(
      "D", [](const model::Parameters& p) { return p.drive.D(); },
      "effective rise fraction C_dr * e_dr");
  cls.def(
      "validate", [](const model::Parameters& p) { piezo::config::require_valid(p, "Parameters"); },
      "Raises ValueError naming the first parameter out of its range.");
  cls.def("to_json", [](const model::Parameters& p) { return host::to_json(p).dump(); });
  cls.def_static("from_json", [](const std::string& text) {
    model::Parameters p = host::parameters_from_json(nlohmann::json::parse(text));
    piezo::config::require_valid(p, "Parameters");
    return p;
  });
  cls.def_static("from_config",
                 [](const std::string& path) { return piezo::config::load_model_config(path); });
  // Pickled as the parameters' JSON and the direction (processes of a pool).
  cls.def(py::pickle(
      [](const model::Parameters& p) {
        return py::make_tuple(host::to_json(p).dump(), std::string(model::name(p.drive.direction)));
      },
      [](const py::tuple& state) {
        model::Parameters p =
            host::parameters_from_json(nlohmann::json::parse(state[0].cast<std::string>()));
        p.drive.direction = host::checked_direction(state[1].cast<std::string>(), "direction");
        return p;
      }));
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
                      double ramp_time) {
            return model::FitData{to_vector(drive_t, "drive_t"), to_vector(drive_V, "drive_V"),
                                  ramp_time, to_vector(t, "t"), to_vector(theta, "theta")};
          }),
          py::arg("drive_t"), py::arg("drive_V"), py::arg("t"), py::arg("theta"),
          py::arg("ramp_time") = 1e-4)
      .def_property_readonly(
          "drive_t", [](const model::FitData& d) { return to_numpy(std::vector(d.drive_t)); })
      .def_property_readonly(
          "drive_V", [](const model::FitData& d) { return to_numpy(std::vector(d.drive_V)); })
      .def_property_readonly("t",
                             [](const model::FitData& d) { return to_numpy(std::vector(d.t)); })
      .def_property_readonly("theta",
                             [](const model::FitData& d) { return to_numpy(std::vector(d.theta)); })
      .def_readonly("ramp_time", &model::FitData::ramp_time);

  py::class_<host::LogLayout>(m, "LogLayout")
      .def(py::init([](std::string t, std::string V, std::string theta, std::string theta_t) {
             return host::LogLayout{std::move(t), std::move(V), std::move(theta),
                                    std::move(theta_t)};
           }),
           py::arg("t") = "", py::arg("V") = "", py::arg("theta") = "", py::arg("theta_t") = "");

  m.def("simulate", &simulate, py::arg("params"), py::arg("duration"), py::arg("model"),
        py::arg("direction"), py::arg("dt"), py::arg("tolerance"), py::arg("integrator"));
  m.def("sensitivity", &sensitivity, py::arg("params"), py::arg("model"));
  m.def("global_study", &global_study, py::arg("params"), py::arg("method"), py::arg("names"),
        py::arg("range_pct"), py::arg("samples"), py::arg("seed"), py::arg("output"),
        py::arg("runtime"), py::arg("bootstrap"), py::arg("model"));
  m.def("sweep", &sweep, py::arg("params"), py::arg("name"), py::arg("values"), py::arg("periods"),
        py::arg("model"));
  m.def("identify", &identify, py::arg("params"), py::arg("data"), py::arg("free"),
        py::arg("model"), py::arg("max_iterations"));
  m.def(
      "observe",
      [](const model::Parameters& p, const model::FitData& data, double alpha, double beta,
         double gate_rad, double latency) {
        return observe(p, data, {alpha, beta, gate_rad}, latency);
      },
      py::arg("params"), py::arg("data"), py::arg("alpha"), py::arg("beta"), py::arg("gate_rad"),
      py::arg("latency"));
  m.def("load_run", &load_run, py::arg("path"), py::arg("layout"));
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
