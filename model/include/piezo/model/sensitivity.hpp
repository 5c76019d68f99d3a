#pragma once
/// @file
/// The paper's section 5 sensitivity study (docs/model.md sections 5 and 6):
/// sweeps, mean velocity, elasticity and ranking. Pure functions; the host
/// decides how to schedule the runs.

#include <string>
#include <vector>

#include "piezo/model/parameters.hpp"
#include "piezo/model/simulate.hpp"

namespace piezo::model {

/// One swept parameter: its name (V0, f, mu or D) and its levels, baseline in the middle.
struct Sweep {
  std::string name;
  std::vector<double> levels;
};

/// The four sweeps of the paper, five levels each, around `base`: the
/// paper's levels (72..88 V, 8..12 Hz, 0.09..0.11, D 0.675..0.825) scaled
/// by the ratio of base's value to Table 1's, to 12 significant digits; at
/// Table 1, the paper's levels exactly. A study is about the parameters it
/// is given.
[[nodiscard]] std::vector<Sweep> paper_sweeps(const Parameters& base = {});

/// Runtime of each sensitivity run [s].
inline constexpr double kSensitivityRuntime = 4.8;

/// `base` with one swept parameter set. D = C_dr*e_dr is applied through
/// e_dr, keeping the commanded C_dr: the top level 0.825 would need a
/// commanded duty ratio above 1 at e_dr = 0.789.
[[nodiscard]] Parameters with_level(const Parameters& base, const std::string& name, double value);

/// Mean rotor velocity theta(t_end)/t_end of a run from rest [rad/s].
[[nodiscard]] double mean_velocity(const Parameters& p, FrictionModel model, double runtime,
                                   const IntegratorSettings& settings = {});

/// Result of one sweep.
struct SweepResult {
  std::string name;
  std::vector<double> levels;
  std::vector<double> mean_velocity;  ///< [rad/s], one per level
  /// Normalised sensitivity: (relative spread of mean velocity over the levels)
  /// / (relative spread of the parameter), signed (negative = inverse influence).
  double elasticity = 0.0;
};

/// Elasticity from levels and velocities, relative to the middle level.
[[nodiscard]] double elasticity(const std::vector<double>& levels,
                                const std::vector<double>& velocities);

/// Parameter names ordered by |elasticity|, strongest first.
[[nodiscard]] std::vector<std::string> rank_by_influence(const std::vector<SweepResult>& results);

}  // namespace piezo::model
