#pragma once
// What identification reads and writes: a measured run from a `piezo run`
// HDF5 log or a CSV with t, V, theta columns, and a fitted parameter set as
// a TOML file that `simulate` and `run` accept.

#include <string>

#include "piezo/model/identify.hpp"
#include "piezo/model/parameters.hpp"

namespace piezo::host {

struct LoadedRun {
  model::FitData data;
  model::Parameters parameters;  ///< the log's [model] (Table 1 for a CSV)
};

/// Where a log from another tool keeps its data: dataset paths in an HDF5
/// file (a MATLAB v7.3 .mat is HDF5), or column names in a CSV. Empty:
/// a `piezo run` log's own layout (CSV: t, V, theta).
struct LogLayout {
  std::string t;        ///< the drive's time [s], and the angle's unless theta_t is given
  std::string V;        ///< amplifier output [V]
  std::string theta;    ///< measured angle [rad]
  std::string theta_t;  ///< the angle's own time [s], if it has one
  [[nodiscard]] bool given() const { return !t.empty() || !V.empty() || !theta.empty(); }
};

/// Reads a `piezo run` log (run.h5), an HDF5 or MATLAB v7.3 file with the
/// datasets `layout` names, or a CSV. Parameters: the log's own, else
/// Table 1 (the caller's --config overrides either).
/// Throws ConfigError naming the file and what is missing.
[[nodiscard]] LoadedRun load_run_for_fit(const std::string& path, const LogLayout& layout = {});

/// Writes [drive] and [model] with every parameter: a config for simulate,
/// and an overlay (`--config rig.toml --config FITTED.toml`) for run.
void write_parameters_toml(const std::string& path, const model::Parameters& p,
                           const std::string& comment);

/// Parses "a,b,c" into names, checking each is a parameter.
[[nodiscard]] std::vector<std::string> parse_parameter_list(const std::string& list);

}  // namespace piezo::host

namespace piezo::host {

/// Settings for a fit run from the CLI: Jacobian columns on all cores,
/// progress on stderr prefixed with `label`.
[[nodiscard]] model::FitSettings cli_fit_settings(const std::vector<std::string>& free,
                                                  model::FrictionModel friction,
                                                  const std::string& label);

}  // namespace piezo::host
