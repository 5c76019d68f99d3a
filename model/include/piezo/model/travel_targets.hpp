#pragma once
/// @file
/// Fitting model parameters to figures a paper reports instead of its logs:
/// the time the rotor takes to cover an angle from rest under the sawtooth
/// (paper Eq. 1), at given drive settings. Each target carries its own
/// settings (the paper's section 4.2: 10 Hz with Table 1's d_e, 20 Hz with
/// d_e = 0.228 um/V); the fit frees the parameters it is told to, shared by
/// every target, as identify() does for a log (Levenberg-Marquardt in log
/// space, the same report).

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "piezo/model/identify.hpp"
#include "piezo/model/parameters.hpp"
#include "piezo/model/simulate.hpp"

namespace piezo::model {

/// "The rotor covered angle_rad in time_s" with these settings overlaid on
/// the fitted parameters (symbols of parameter_specs(), e.g. {"f", 20}).
struct TravelTarget {
  std::vector<std::pair<std::string, double>> settings;
  double angle_rad = 0.0;
  double time_s = 0.0;
};

/// When the rotor, driven from rest by p's sawtooth, has covered angle_rad
/// (its sign says the direction): its angle read at the end of each period
/// (the drive at 0 V), interpolated between the two periods whose ends lie
/// either side; NaN when it does not within t_max_s.
[[nodiscard]] double travel_time(const Parameters& p, double angle_rad, FrictionModel model,
                                 double t_max_s, double tolerance = 1e-7);

/// `start` with a target's settings overlaid; throws std::invalid_argument
/// naming an unknown symbol or a value out of its range.
[[nodiscard]] Parameters with_settings(const Parameters& start, const TravelTarget& target);

/// How the fit met one target.
struct TargetOutcome {
  double model_time_s = 0.0;    ///< NaN: the angle was not reached within 3x the target's time
  double relative_error = 0.0;  ///< model_time_s / time_s - 1
};

struct TargetFitResult {
  FitResult fit;  ///< the parameters, their values and (with more targets than free
                  ///< parameters) standard errors and intervals; rmse_rad is unused (0)
  std::vector<TargetOutcome> targets;  ///< at the start values, then at the optimum
  std::vector<TargetOutcome> initial_targets;
};

/// A free name's parameter and whose it is: "F_N" is every target's (0),
/// "d_e@2" target 2's own (1-based). Throws std::invalid_argument naming a
/// number that is not a target's.
[[nodiscard]] inline std::pair<std::string, std::size_t> split_free_name(const std::string& name,
                                                                         std::size_t targets) {
  const std::size_t at = name.find('@');
  if (at == std::string::npos) return {name, 0};
  const std::string number = name.substr(at + 1);
  std::size_t k = 0;
  if (number.empty() || number.size() > 6 ||
      number.find_first_not_of("0123456789") != std::string::npos || (k = std::stoul(number)) < 1 ||
      k > targets) {
    throw std::invalid_argument("targets: " + name + ": after @ a target's number, 1 to " +
                                std::to_string(targets));
  }
  return {name.substr(0, at), k};
}

/// Fits settings.free (at most as many as there are targets) to the
/// targets' times, minimising the sum of squared log time ratios. A name is
/// shared by every target ("F_N") or one target's own ("d_e@2", fitted for
/// target 2 alone; a target may not also set it). FitResult::parameters
/// holds the shared values; `fitted` every value under its name. Throws
/// std::invalid_argument for unknown or unfittable names, too few targets,
/// or a target without a positive angle and time.
[[nodiscard]] TargetFitResult fit_travel_targets(const Parameters& start,
                                                 const std::vector<TravelTarget>& targets,
                                                 const FitSettings& settings);

}  // namespace piezo::model
