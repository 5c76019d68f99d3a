#pragma once
// Parameters as JSON objects keyed by the paper's symbols.

#include <nlohmann/json.hpp>

#include "piezo/model/parameters.hpp"

namespace piezo::host {

[[nodiscard]] nlohmann::json to_json(const model::Parameters& p);
/// The inverse of to_json: Table 1 defaults overlaid with the entries given.
[[nodiscard]] model::Parameters parameters_from_json(const nlohmann::json& j);

}  // namespace piezo::host
