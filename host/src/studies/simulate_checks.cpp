#include "simulate_checks.hpp"

#include <fmt/format.h>

#include "piezo/config/config_error.hpp"

namespace piezo::host {

model::FrictionModel checked_friction_model(const std::string& text, const std::string& key) {
  const auto friction = model::parse_friction_model(text);
  if (!friction) throw config::ConfigError(key, text, "allowed: lugre, coulomb");
  return *friction;
}

model::Direction checked_direction(const std::string& text, const std::string& key) {
  const auto direction = model::parse_direction(text);
  if (!direction) throw config::ConfigError(key, text, "allowed: forward, reverse");
  return *direction;
}

model::Integrator checked_integrator(const std::string& text, model::FrictionModel friction,
                                     const std::string& key) {
  const auto integrator = model::parse_integrator(text);
  if (!integrator) {
    throw config::ConfigError(key, text,
                              "allowed: model_default, dopri5, closed_form (Coulomb only), "
                              "hybrid (LuGre only)");
  }
  if (*integrator == model::Integrator::closed_form && friction == model::FrictionModel::lugre) {
    throw config::ConfigError(key, text,
                              "closed_form solves the Coulomb model only; LuGre: hybrid or dopri5");
  }
  if (*integrator == model::Integrator::hybrid && friction == model::FrictionModel::coulomb) {
    throw config::ConfigError(key, text,
                              "hybrid solves the LuGre model only; Coulomb: closed_form or dopri5");
  }
  return *integrator;
}

void check_duration(double seconds, const std::string& key) {
  if (!(seconds > 0.0 && seconds <= kMaxSimulatedDuration_s)) {
    throw config::ConfigError(key, fmt::format("{:g} s", seconds),
                              fmt::format("allowed: (0, {:g}] s", kMaxSimulatedDuration_s));
  }
}

}  // namespace piezo::host
