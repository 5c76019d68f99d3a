#pragma once
// What identification reads and writes: a measured run from a `piezo run`
// HDF5 log or a CSV with t, V, theta columns, and a fitted parameter set as
// a TOML file that `simulate` and `run` accept.

#include <optional>
#include <string>
#include <vector>

#include "piezo/model/identify.hpp"
#include "piezo/model/parameters.hpp"
#include "piezo/model/travel_targets.hpp"

namespace piezo::host {

class H5File;

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
  /// A `piezo` log of several axes: the axis to read (required there).
  std::string axis;
  [[nodiscard]] bool given() const { return !t.empty() || !V.empty() || !theta.empty(); }
};

/// Reads a `piezo run` log (run.h5), an HDF5 or MATLAB v7.3 file with the
/// datasets `layout` names, or a CSV. Parameters: the log's own, else
/// Table 1 (the caller's --config overrides either).
/// Throws ConfigError naming the file and what is missing.
[[nodiscard]] LoadedRun load_run_for_fit(const std::string& path, const LogLayout& layout = {});

/// The group of `axis` in the `piezo` log `log` (read from `path`): "" (the
/// root) in a log of one axis, "/axes/AXIS" in a log of several. Throws
/// ConfigError (key --axis) for an axis missing where the log has several,
/// or one the log does not hold, naming those it does.
[[nodiscard]] std::string axis_group_of(const H5File& log, const std::string& path,
                                        const std::string& axis);

/// Writes [drive] and [model] with every parameter: a config for simulate,
/// and an overlay (`--config rig.toml --config FITTED.toml`) for run.
void write_parameters_toml(const std::string& path, const model::Parameters& p,
                           const std::string& comment);

/// A reported figure for `piezo identify --target`:
/// "f=20,d_e=0.228e-6,angle=0.010,time=1.36", `angle` [rad] and `time` [s]
/// required, every other key a parameter symbol this target runs with.
/// Throws ConfigError naming --target, the text and what is wrong.
[[nodiscard]] model::TravelTarget parse_travel_target(const std::string& text);

/// Parses "a,b,c" into names, checking each is a parameter.
[[nodiscard]] std::vector<std::string> parse_parameter_list(const std::string& list);

/// The parameters a fit frees: `free`, each a Table 1 symbol that `model`
/// uses, named once, at least one; none named (nullopt): the model's
/// defaults. `source` and `key` are the caller's words for the list
/// ("identify", "--params" or "free"). Throws ConfigError.
[[nodiscard]] std::vector<std::string> checked_free_parameters(
    const std::optional<std::vector<std::string>>& free, model::FrictionModel model,
    const std::string& source, const std::string& key);

/// The same for a fit to `targets` travel targets: a name may carry a
/// target's number ("d_e@2": target 2's own value; 1-based). Throws ConfigError.
[[nodiscard]] std::vector<std::string> checked_target_free_parameters(
    const std::optional<std::vector<std::string>>& free, model::FrictionModel friction,
    std::size_t targets, const std::string& source, const std::string& key);

/// The typical interval of strictly increasing times: their median step.
[[nodiscard]] double median_interval(const std::vector<double>& t);

/// Checks a run given as arrays (Python's identify and observe): the drive
/// two or more finite samples at non-decreasing times (a run's stop record
/// may repeat the last), one volt each; the angle's times finite and
/// non-decreasing, one angle each (NaN: a failed reading; infinite:
/// refused). Throws ConfigError naming `source` (the function) and the
/// argument.
void check_run_arrays(const std::vector<double>& drive_t, const std::vector<double>& drive_V,
                      const std::vector<double>& t, const std::vector<double>& theta,
                      const std::string& source);

/// A fit's data from arrays, checked (check_run_arrays) and taken as a log
/// is read: a repeated drive time and readings that failed or came before
/// t = 0 left out. ramp_time unset: the drive's median interval, as for a
/// log.
[[nodiscard]] model::FitData checked_fit_data(const std::vector<double>& drive_t,
                                              const std::vector<double>& drive_V,
                                              const std::vector<double>& t,
                                              const std::vector<double>& theta,
                                              std::optional<double> ramp_time,
                                              const std::string& source);

}  // namespace piezo::host

namespace piezo::host {

/// Settings for a fit run from the CLI: Jacobian columns on all cores,
/// progress on stderr prefixed with `label`.
[[nodiscard]] model::FitSettings cli_fit_settings(const std::vector<std::string>& free,
                                                  model::FrictionModel friction,
                                                  const std::string& label);

/// The same for a fit to travel targets: its progress is the RMS of the
/// targets' log time ratios.
[[nodiscard]] model::FitSettings cli_target_fit_settings(const std::vector<std::string>& free,
                                                         model::FrictionModel friction,
                                                         const std::string& label);

}  // namespace piezo::host
