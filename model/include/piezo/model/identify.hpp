#pragma once
/// @file
/// Fitting model parameters to a measured run: nonlinear least squares on
/// the angle (Levenberg-Marquardt from Eigen's unsupported module), the
/// model driven by the logged drive samples so that any waveform works.
/// Parameters are fitted in log space, which keeps them positive; each is
/// also held within its allowed range. Standard errors and 95 % intervals
/// come from the Jacobian at the optimum.

#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "piezo/model/parameters.hpp"
#include "piezo/model/simulate.hpp"

namespace piezo::model {

/// A measured run: the commanded drive and the measured angle.
struct FitData {
  std::vector<double> drive_t, drive_V;  ///< strictly increasing times [s], volts
  double ramp_time = 1e-4;               ///< the signal chain reaches each command over this [s]
  std::vector<double> t, theta;          ///< measurement times [s] (non-decreasing), angles [rad]
};

/// The parameters a fit frees unless told otherwise: LuGre sigma0, sigma1,
/// F_N and d_e; Coulomb, which has no bristles, F_N and d_e.
[[nodiscard]] inline std::vector<std::string> default_free_parameters(FrictionModel model) {
  if (model == FrictionModel::coulomb) return {"F_N", "d_e"};
  return {"sigma0", "sigma1", "F_N", "d_e"};
}

/// Whether `model` uses the parameter at all: Coulomb friction has no
/// bristles, so sigma0, sigma1 and sigma2 change nothing there (a fit of
/// them would report zero-width intervals).
[[nodiscard]] inline bool model_uses(FrictionModel model, std::string_view name) {
  return model != FrictionModel::coulomb ||
         (name != "sigma0" && name != "sigma1" && name != "sigma2");
}

struct FitSettings {
  std::vector<std::string> free{"sigma0", "sigma1", "F_N", "d_e"};
  FrictionModel model = FrictionModel::lugre;
  int max_iterations = 40;
  double tolerance = 1e-7;  ///< integrator tolerance: finite differences need a smooth residual
  /// Runs job(i) for i in [0, n): serial by default; the host passes a parallel one.
  std::function<void(std::size_t, const std::function<void(std::size_t)>&)> for_each =
      [](std::size_t n, const std::function<void(std::size_t)>& job) {
        for (std::size_t i = 0; i < n; ++i) job(i);
      };
  /// Called after each iteration with its number and the RMSE [rad].
  std::function<void(int, double)> progress = [](int, double) {};
  /// Handed to every simulation of the fit (IntegratorSettings::progress):
  /// one iteration's simulations can take minutes on a stiff parameter
  /// set, and the caller stops them by throwing from it; may be empty.
  std::function<void(double t)> within_simulation = {};
};

struct FittedParameter {
  std::string name;
  double value;
  double standard_error;
  double low95, high95;  ///< 95 % confidence interval (from the log-space estimate)
};

struct FitResult {
  Parameters parameters;  ///< the start, with the free parameters fitted
  std::vector<FittedParameter> fitted;
  double rmse_rad = 0.0;  ///< paper Eq. 7 at the optimum
  double initial_rmse_rad = 0.0;
  int iterations = 0;
  /// Whether Levenberg-Marquardt met its tolerances; when not, the values
  /// are where it stopped and the intervals, which assume an optimum, mean
  /// nothing (the notes say so).
  bool converged = false;
  std::string stop_reason;         ///< why it stopped, in words
  std::vector<std::string> notes;  ///< identifiability warnings
  std::vector<double> theta_fit;   ///< the fitted model at the measurement times
};

/// The model's angle at data.t, driven by data's drive samples.
[[nodiscard]] std::vector<double> predict(const Parameters& p, const FitData& data,
                                          FrictionModel model, double tolerance = 1e-6,
                                          const std::function<void(double)>& progress = {});

/// Fits settings.free, starting from `start`. Throws std::invalid_argument
/// for unknown or unfittable names and for empty data.
[[nodiscard]] FitResult identify(const Parameters& start, const FitData& data,
                                 const FitSettings& settings = {});

}  // namespace piezo::model
