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
  if (settings.free.empty()) throw std::invalid_argument("identify: no parameter to fit");
  std::vector<detail::Unknown> unknowns;
  for (const auto& name : settings.free) {
    const ParameterSpec* s = detail::free_spec(start, name, settings.model, "identify");
    unknowns.push_back({s, name, *get_parameter(start, name)});
  }
  if (data.t.size() < settings.free.size() + 2 || data.t.size() != data.theta.size()) {
    throw std::invalid_argument("identify: too few measurements");
  }
  const auto with_values = [&](const std::vector<double>& values) {
    Parameters p = start;
    for (std::size_t i = 0; i < unknowns.size(); ++i) unknowns[i].spec->ref(p) = values[i];
    return p;
  };
  // The model's angle at each measurement time, less the measured one.
  const auto residuals = [&](const std::vector<double>& values, Eigen::VectorXd& r) {
    const auto theta = predict(with_values(values), data, settings.model, settings.tolerance,
                               settings.within_simulation);
    for (std::size_t i = 0; i < theta.size(); ++i) {
      r[static_cast<Eigen::Index>(i)] = theta[i] - data.theta[i];
    }
  };
  const detail::LogSpaceFit fit = detail::fit_in_log_space(
      unknowns, static_cast<int>(data.t.size()), residuals, settings, kAngleDifferenceStep);
  FitResult result;
  result.parameters = with_values(fit.values);
  result.initial_rmse_rad = detail::rms(fit.initial_residuals);
  result.rmse_rad = detail::rms(fit.residuals);
  result.iterations = fit.iterations;
  result.converged = fit.converged;
  result.stop_reason = fit.stop_reason;
  result.theta_fit = predict(result.parameters, data, settings.model, settings.tolerance);
  result.fitted = detail::fitted_parameters(unknowns, fit);
  result.notes = detail::fit_notes(unknowns, fit);
  return result;
}

}  // namespace piezo::model
