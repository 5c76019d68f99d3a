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

/// Reads FILE.h5 (a run log) or FILE.csv (header row with t, V, theta; SI).
/// Throws ConfigError naming the file and what is missing.
[[nodiscard]] LoadedRun load_run_for_fit(const std::string& path);

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
