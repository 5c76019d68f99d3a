#pragma once
// Parameters as JSON objects keyed by the paper's symbols.

#include <nlohmann/json.hpp>

#include "piezo/model/parameters.hpp"

namespace piezo::host {

[[nodiscard]] nlohmann::json to_json(const model::Parameters& p);

}  // namespace piezo::host
