#pragma once
// What a run used, defaults included, as TOML: the run directory's
// config.toml when the run had no config file of its own (a board driven
// with --rig alone), and the summary under the file's text otherwise.

#include <string>

#include "config_file.hpp"

namespace piezo::config {

/// Every value the config holds, defaults included, as the readers declare
/// their keys (effective_keys): the board's and the host's sections with the
/// first axis's as the base, then every axis's own under [axes.NAME], each
/// kind's chosen backend alone. Loadable by load_config_file.
[[nodiscard]] std::string effective_config_toml(const ConfigFile& c);

/// The run directory's config.toml: the config's own text (files and
/// --set lines), then the effective values as comments; or, with no text
/// at all, the effective values as TOML.
[[nodiscard]] std::string run_config_file(const ConfigFile& c);

}  // namespace piezo::config
