#pragma once
// Loading the paper's parameters from a TOML config ([drive] and [model])
// and from --set KEY=VALUE overrides, with every bad value reported by key
// and source.

#include <toml++/toml.h>

#include <string>
#include <string_view>
#include <vector>

#include "piezo/config/section_reader.hpp"
#include "piezo/model/parameters.hpp"

namespace piezo::config {

/// Reads the waveform keys of [drive] (V0, f, C_dr, e_dr) into `p`; keys
/// absent keep their value.
void read_waveform(SectionReader& drive, model::Parameters& p);

/// Reads the motor parameters (d_e ... sigma2) of a section such as [model]
/// or [plant] into `motor`; keys absent keep their value.
void read_motor(SectionReader& section, model::MotorParameters& motor);

/// Parses a number strictly: the whole text, finite. Throws ConfigError.
double parse_number(const std::string& text, const std::string& source, const std::string& key);

/// Sets one parameter by its paper symbol, refusing an unknown name or a
/// value outside its range (ConfigError from `source`, naming it and the
/// range): `--set` and the Python package's Parameters.
void set_parameter(model::Parameters& p, const std::string& name, double value,
                   const std::string& source);

/// Applies "KEY=VALUE" (KEY a paper symbol) to `p`. Throws ConfigError.
void apply_parameter_override(const std::string& assignment, model::Parameters& p);

/// Throws ConfigError for the first issue of model::validate, naming `source`.
void require_valid(const model::Parameters& p, const std::string& source);

}  // namespace piezo::config

namespace piezo::config {

/// Throws ConfigError (naming `source` and the line) at the first non-ASCII
/// byte outside a comment.
void require_ascii_outside_comments(std::string_view text, const std::string& source);

/// A config file's text; ConfigError (naming the file) when it cannot be read.
[[nodiscard]] std::string read_config_file(const std::string& path);
/// Parses a config's text (from `path`); parse errors become ConfigError
/// with file and line.
[[nodiscard]] toml::table parse_config_text(const std::string& text, const std::string& path);
/// Both at once.
[[nodiscard]] toml::table parse_config_file(const std::string& path);

}  // namespace piezo::config
