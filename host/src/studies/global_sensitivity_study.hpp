#pragma once
// `piezo sensitivity --method morris|sobol`: every chosen parameter varied
// at once over ±P % of its baseline, the motor simulated on each row of the
// design (all cores, progress on stderr), the indices with their plots.

#include <array>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "piezo/model/parameters.hpp"
#include "piezo/model/simulate.hpp"

namespace piezo::host {

/// What the caller calls each option, so that an error names what the user
/// typed: the CLI's flags by default, piezo_rig's keyword arguments there.
struct StudyOptionNames {
  std::string params = "--params";
  std::string range = "--range";
  std::string samples = "--samples";
  std::string output = "--output";
  std::string runtime = "--runtime";
  std::string bootstrap = "--bootstrap";
};

/// What a global study measures of each run: its mean velocity, a step, the backslip.
inline constexpr std::array<std::string_view, 3> kStudyOutputs{"velocity", "step", "backslip"};

struct GlobalStudyOptions {
  std::string method;               ///< "morris" or "sobol"
  std::vector<std::string> params;  ///< empty: every Table 1 parameter
  double range_pct = 10.0;
  std::size_t samples = 0;  ///< Sobol' N (>= 8), or Morris trajectories (>= 2)
  std::uint64_t seed = 1;
  std::string output = "velocity";  ///< one of kStudyOutputs
  double runtime_s = 4.8;
  int bootstrap = 200;
  model::FrictionModel model = model::FrictionModel::lugre;
  std::string out;
  bool json = false;
  StudyOptionNames names;
};

/// Sobol' N, or Morris trajectories, when none is asked for: 1024 / 20.
std::size_t default_samples(const std::string& method);

/// Validates the options, simulates the design and returns the indices as
/// `--json` prints them (writing tables and plots to o.out when set); null
/// on MPI ranks other than 0.
nlohmann::json global_study(const model::Parameters& base, const GlobalStudyOptions& o);

/// global_study, printed as a table or (o.json) as one JSON object.
int run_global_study(const model::Parameters& base, const GlobalStudyOptions& o);

}  // namespace piezo::host
