#pragma once
// The paper's section 5 study, one parameter at a time: V0, f, mu and D at
// five levels each, 4.8 s from rest per level (all cores, progress on
// stderr). `piezo sensitivity` and the Python package's
// `piezo_rig.model.sensitivity` both run it.

#include <cstddef>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "piezo/model/sensitivity.hpp"
#include "piezo/model/simulate.hpp"

namespace piezo::host {

/// One level of one sweep, with its angle trace (sampled every 1 ms).
struct LevelRun {
  std::size_t sweep;
  std::size_t level;
  model::Trajectory trace;
};

struct OatStudy {
  std::vector<LevelRun> runs;
  std::vector<model::SweepResult> results;  ///< one per sweep, in the paper's order
  std::vector<std::string> ranking;         ///< strongest influence first
};

/// Checks every level (config::ConfigError naming it) before simulating any.
[[nodiscard]] OatStudy oat_study(const model::Parameters& base, model::FrictionModel friction);

/// The study as `piezo sensitivity --json` prints it.
[[nodiscard]] nlohmann::json to_json(const OatStudy& study, std::string_view model);

}  // namespace piezo::host
