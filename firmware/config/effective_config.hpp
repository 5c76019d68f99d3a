#pragma once
// What a run used, defaults included, as TOML: the run directory's
// config.toml when the run had no config file of its own (a board driven
// with --rig alone), and the summary under the file's text otherwise.

#include <string>

#include "config_file.hpp"

namespace piezo::config {

/// The host-side values a run uses: [drive] (waveform, direction, rate,
/// limits), [model], [sensor] r2_m and rate, [run] duration and clock,
/// [observer], and [rig] address and lease. Loadable by load_config_file.
[[nodiscard]] std::string effective_config_toml(const ConfigFile& c);

/// The run directory's config.toml: the config's own text (files and
/// --set lines), then the effective values as comments; or, with no text
/// at all, the effective values as TOML.
[[nodiscard]] std::string run_config_file(const ConfigFile& c);

}  // namespace piezo::config
