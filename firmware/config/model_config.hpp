#pragma once
// Loading the paper's parameters from a TOML config ([drive] and [model])
// and from --set KEY=VALUE overrides, with every bad value reported by key
// and source.

#include <toml++/toml.h>

#include <string>
#include <vector>

#include "piezo/model/parameters.hpp"

namespace piezo::config {

/// Reads [drive] V0, f, C_dr, e_dr and [model] d_e ... sigma2 from `table`
/// into `p` (keys absent keep their value). Keys in those sections that are
/// not parameters are errors unless listed in `extra_drive_keys`; other
/// sections are left to the caller.
void read_model_sections(const toml::table& table, const std::string& source, model::Parameters& p,
                         const std::vector<std::string>& extra_drive_keys = {});

/// Reads one section of parameter keys (e.g. [plant]) into the motor part of `p`.
void read_motor_section(const toml::table& table, const std::string& section,
                        const std::string& source, model::MotorParameters& motor);

/// Parses a number strictly: the whole text, finite. Throws ConfigError.
double parse_number(const std::string& text, const std::string& source, const std::string& key);

/// Applies "KEY=VALUE" (KEY a paper symbol) to `p`. Throws ConfigError.
void apply_parameter_override(const std::string& assignment, model::Parameters& p);

/// Throws ConfigError for the first issue of model::validate, naming `source`.
void require_valid(const model::Parameters& p, const std::string& source);

}  // namespace piezo::config

namespace piezo::config {

/// Sections a project config may hold; those other commands own are skipped
/// by the model reader but an unknown one is an error everywhere.
inline const std::vector<std::string> kKnownSections{"drive",    "model",  "plant",  "sensor",
                                                     "lines",    "run",    "safety", "rig_sim",
                                                     "observer", "piezod", "rig"};
/// [drive] keys that belong to the real-time drive, not to the model.
inline const std::vector<std::string> kDriveLoopKeys{"backend",
                                                     "rate_hz",
                                                     "V_min",
                                                     "V_max",
                                                     "slew_V_per_s",
                                                     "dac_bits",
                                                     "dac_full_scale_V",
                                                     "amplifier_gain",
                                                     "amplifier_V_max",
                                                     "amplifier_slew_V_per_s",
                                                     "ao_host",
                                                     "ao_port",
                                                     "ao_unit_id",
                                                     "ao_address",
                                                     "ao_counts_per_V",
                                                     "ao_full_scale_V",
                                                     "ao_timeout_s",
                                                     "ao_watchdog_registers",
                                                     "ao_watchdog_values",
                                                     "ao_watchdog_s",
                                                     "ao_link_loss_acknowledged",
                                                     "gpio_chip",
                                                     "dac_data_offsets",
                                                     "dac_strobe_offset",
                                                     "dac_data_active_low",
                                                     "dac_strobe_active_low"};

/// Parses a TOML file; parse errors become ConfigError with file and line.
[[nodiscard]] toml::table parse_config_file(const std::string& path);

/// Table 1 defaults overlaid with a config file's [drive] and [model].
[[nodiscard]] model::Parameters load_model_config(const std::string& path);

}  // namespace piezo::config

// The host reads rig configs through the same names.
namespace piezo::host {
using namespace piezo::config;  // NOLINT(google-build-using-namespace)
}  // namespace piezo::host
