#include "piezo/model/identify.hpp"

#include <stdexcept>

#include "log_space_fit.hpp"
#include "piezo/model/sampled_drive.hpp"

namespace piezo::model {
namespace {

/// The Jacobian's step in log space: 0.1 % of each parameter (the angle at
/// each sample is smooth in the parameters).
constexpr double kAngleDifferenceStep = 1e-3;

}  // namespace

std::vector<double> predict(const Parameters& p, const FitData& data, FrictionModel model,
                            double tolerance, const std::function<void(double)>& progress) {
  const SampledDrive drive(data.drive_t, data.drive_V, data.ramp_time);
  std::vector<double> times(data.t);
  for (double& t : times) t = std::max(t, 0.0);
  return simulate(p.motor, drive, model, times, {.tolerance = tolerance, .progress = progress})
      .theta;
}

FitResult identify(const Parameters& start, const FitData& data, const FitSettings& settings) {
  const auto specs = detail::free_specs(start, settings, "identify");
  if (data.t.size() < settings.free.size() + 2 || data.t.size() != data.theta.size()) {
    throw std::invalid_argument("identify: too few measurements");
  }
  // The model's angle at each measurement time, less the measured one.
  const auto residuals = [&](const Parameters& p, Eigen::VectorXd& r) {
    const auto theta =
        predict(p, data, settings.model, settings.tolerance, settings.within_simulation);
    for (std::size_t i = 0; i < theta.size(); ++i) {
      r[static_cast<Eigen::Index>(i)] = theta[i] - data.theta[i];
    }
  };
  const detail::LogSpaceFit fit = detail::fit_in_log_space(
      start, specs, static_cast<int>(data.t.size()), residuals, settings, kAngleDifferenceStep);
  FitResult result;
  result.parameters = fit.parameters;
  result.initial_rmse_rad = detail::rms(fit.initial_residuals);
  result.rmse_rad = detail::rms(fit.residuals);
  result.iterations = fit.iterations;
  result.converged = fit.converged;
  result.stop_reason = fit.stop_reason;
  result.theta_fit = predict(result.parameters, data, settings.model, settings.tolerance);
  result.fitted = detail::fitted_parameters(specs, fit);
  result.notes = detail::fit_notes(specs, fit);
  return result;
}

}  // namespace piezo::model
