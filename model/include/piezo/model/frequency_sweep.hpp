#pragma once
/// @file
/// One parameter swept over a wide range (the paper's future work: "a
/// broader frequency range"), each point simulated for a set number of
/// drive periods so that every point costs about the same, and measured
/// per period: mean velocity, forward step, backward slip.

#include <cstddef>
#include <string>
#include <vector>

#include "piezo/model/parameters.hpp"
#include "piezo/model/simulate.hpp"

namespace piezo::model {

struct StepMetrics {
  double mean_velocity_rad_s = 0.0;  ///< theta(t_end) / t_end
  double step_rad = 0.0;             ///< net angle per period, over the periods after settling
  /// Backward slip per period: how far the rotor falls back from the
  /// period's highest angle by the period's end (docs/model.md section 2: the
  /// fast edge drags the rotor back where friction cannot hold it).
  double backslip_rad = 0.0;
  std::size_t integrator_steps = 0;
};

struct PeriodSettings {
  int periods = 20;        ///< simulated drive periods
  int settle_periods = 2;  ///< periods left out of the per-period figures
  int samples_per_period = 200;
};

/// Simulates `periods` drive periods of `p` from rest and measures them.
[[nodiscard]] StepMetrics period_metrics(const Parameters& p, FrictionModel model,
                                         const PeriodSettings& settings = {},
                                         const IntegratorSettings& integrator = {});

/// `points` values from `from` to `to`, evenly spaced, or geometrically when `log`.
[[nodiscard]] std::vector<double> sweep_values(double from, double to, int points, bool log);

}  // namespace piezo::model
