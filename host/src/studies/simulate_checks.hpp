#pragma once
// The checks of a simulation request, one rule for `piezo simulate` and the
// Python package: each throws config::ConfigError naming the option (`key`,
// "--model" on the command line, "model" in Python) and what is allowed.

#include <string>

#include "piezo/model/simulate.hpp"

namespace piezo::host {

/// An hour of motor time takes about ten seconds to simulate; beyond that a
/// duration is a typo (1e300 would run forever).
inline constexpr double kMaxSimulatedDuration_s = 3600.0;

[[nodiscard]] model::FrictionModel checked_friction_model(const std::string& text,
                                                          const std::string& key);
[[nodiscard]] model::Direction checked_direction(const std::string& text, const std::string& key);
/// The integrator named, refused where it cannot solve `friction`.
[[nodiscard]] model::Integrator checked_integrator(const std::string& text,
                                                   model::FrictionModel friction,
                                                   const std::string& key);
void check_duration(double seconds, const std::string& key);

}  // namespace piezo::host
