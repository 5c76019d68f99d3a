// The names of simulate's choices (the friction model, the integrator) as
// the CLI, the configs and Python spell them: one table each, apart from
// the integrators, so that code that only names a model (the fit's
// checks, the logs' fuzz target) needs none of them.

#include "piezo/model/simulate.hpp"

namespace piezo::model {

namespace {

constexpr auto kFrictionModelNames =
    names<FrictionModel>({{FrictionModel::lugre, "lugre"}, {FrictionModel::coulomb, "coulomb"}});
constexpr auto kIntegratorNames = names<Integrator>({{Integrator::model_default, "model_default"},
                                                     {Integrator::dopri5, "dopri5"},
                                                     {Integrator::closed_form, "closed_form"},
                                                     {Integrator::hybrid, "hybrid"}});

}  // namespace

std::string_view to_string(FrictionModel m) {
  return kFrictionModelNames.name(m);
}

std::optional<FrictionModel> parse_friction_model(std::string_view text) {
  return kFrictionModelNames.parse(text);
}

std::string_view to_string(Integrator i) {
  return kIntegratorNames.name(i);
}

std::optional<Integrator> parse_integrator(std::string_view text) {
  if (text == "taylor") return Integrator::hybrid;  // the name of its first form (series only)
  return kIntegratorNames.parse(text);
}

std::vector<std::string_view> friction_model_names() {
  std::vector<std::string_view> out;
  for (const auto& [value, name] : kFrictionModelNames.entries()) out.push_back(name);
  return out;
}

std::vector<std::string_view> integrator_names() {
  std::vector<std::string_view> out;
  for (const auto& [value, name] : kIntegratorNames.entries()) out.push_back(name);
  return out;
}

}  // namespace piezo::model
