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
