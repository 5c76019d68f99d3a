#include "parameters_json.hpp"

namespace piezo::host {

nlohmann::json to_json(const model::Parameters& p) {
  nlohmann::json out = nlohmann::json::object();
  for (const auto& spec : model::parameter_specs()) {
    out[std::string(spec.name)] = *model::get_parameter(p, spec.name);
  }
  return out;
}

}  // namespace piezo::host

namespace piezo::host {

model::Parameters parameters_from_json(const nlohmann::json& j) {
  model::Parameters p;
  for (const auto& [key, value] : j.items()) {
    const model::ParameterSpec* spec = model::find_parameter(key);
    if (spec == nullptr || !value.is_number()) {
      throw std::runtime_error("parameters: unknown or non-numeric entry '" + key + "'");
    }
    spec->ref(p) = value.get<double>();
  }
  return p;
}

}  // namespace piezo::host
