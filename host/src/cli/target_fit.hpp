#pragma once
// `piezo identify --target`: a fit to figures a paper reports (the time to
// cover an angle at given drive settings) instead of to a log.

#include <string>
#include <vector>

#include "piezo/model/travel_targets.hpp"

namespace piezo::host {

struct TargetFitOptions {
  std::vector<std::string> targets;  ///< --target, each as parse_travel_target reads it
  std::string params;                ///< --params; empty: the model's defaults
  std::string model = "lugre";
  std::string config;  ///< start values; empty: Table 1
  std::string out;
  int max_iterations = 40;
  bool json = false;
};

/// The fit, its report (text or JSON) on stdout and the parameters as TOML
/// with --out. Returns the exit code.
int run_target_fit(const TargetFitOptions& o);

}  // namespace piezo::host
