#pragma once
// The least-squares fit that identify() (a log's angles) and
// fit_travel_targets() (a paper's figures) share: Levenberg-Marquardt over
// the free parameters' logarithms (which keeps them positive), each held
// within its allowed range, and the covariance from the Jacobian at the end.

#include <Eigen/Dense>
#include <functional>
#include <string>
#include <vector>

#include "piezo/model/identify.hpp"
#include "piezo/model/parameters.hpp"

namespace piezo::model::detail {

/// The free parameters' specs, checked: known, used by the model, positive.
/// `who` names the caller in the messages ("identify").
[[nodiscard]] std::vector<const ParameterSpec*> free_specs(const Parameters& start,
                                                           const FitSettings& settings,
                                                           const std::string& who);

struct LogSpaceFit {
  Parameters parameters;  ///< the start with the free parameters at the end of the fit
  Eigen::VectorXd initial_residuals, residuals;
  Eigen::MatrixXd covariance;  ///< in log space; empty when there are no degrees of freedom
  Eigen::MatrixXd correlation;
  int iterations = 0;
  bool converged = false;
  std::string stop_reason;
};

/// Fits `specs` from `start` so that `residuals(parameters, r)` (r has
/// `values` entries) is least in the squares' sense; the Jacobian by
/// central differences of `difference_step` in log space (1e-3: 0.1 % of
/// each parameter).
[[nodiscard]] LogSpaceFit fit_in_log_space(
    const Parameters& start, const std::vector<const ParameterSpec*>& specs, int values,
    const std::function<void(const Parameters&, Eigen::VectorXd&)>& residuals,
    const FitSettings& settings, double difference_step);

/// Each fitted parameter's value and, where the covariance is defined, its
/// standard error and 95 % interval (else NaN).
[[nodiscard]] std::vector<FittedParameter> fitted_parameters(
    const std::vector<const ParameterSpec*>& specs, const LogSpaceFit& fit);

/// Warnings about what the data cannot tell apart, and a fit that did not converge.
[[nodiscard]] std::vector<std::string> fit_notes(const std::vector<const ParameterSpec*>& specs,
                                                 const LogSpaceFit& fit);

[[nodiscard]] double rms(const Eigen::VectorXd& r);

}  // namespace piezo::model::detail
