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

/// One value a fit frees: the parameter it is (range, positivity), the
/// name it is reported under ("F_N", or "d_e@2" for one target's own) and
/// where it starts.
struct Unknown {
  const ParameterSpec* spec;
  std::string name;
  double start;
};

/// The free parameters' specs, checked: known, used by the model, positive
/// in `start`. `who` names the caller in the messages ("identify").
[[nodiscard]] const ParameterSpec* free_spec(const Parameters& start, const std::string& name,
                                             FrictionModel model, const std::string& who);

struct LogSpaceFit {
  std::vector<double> values;  ///< each unknown's value at the end of the fit
  Eigen::VectorXd initial_residuals, residuals;
  Eigen::MatrixXd covariance;  ///< in log space; empty when there are no degrees of freedom
  Eigen::MatrixXd correlation;
  int iterations = 0;
  bool converged = false;
  std::string stop_reason;
};

/// Fits the unknowns so that `residuals(values, r)` (r has `count`
/// entries) is least in the squares' sense, each value within its
/// parameter's range; the Jacobian by central differences of
/// `difference_step` in log space (1e-3: 0.1 % of each value).
[[nodiscard]] LogSpaceFit fit_in_log_space(
    const std::vector<Unknown>& unknowns, int count,
    const std::function<void(const std::vector<double>&, Eigen::VectorXd&)>& residuals,
    const FitSettings& settings, double difference_step);

/// Each unknown's value and, where the covariance is defined, its
/// standard error and 95 % interval (else NaN).
[[nodiscard]] std::vector<FittedParameter> fitted_parameters(const std::vector<Unknown>& unknowns,
                                                             const LogSpaceFit& fit);

/// Warnings about what the data cannot tell apart, and a fit that did not converge.
[[nodiscard]] std::vector<std::string> fit_notes(const std::vector<Unknown>& unknowns,
                                                 const LogSpaceFit& fit);

[[nodiscard]] double rms(const Eigen::VectorXd& r);

}  // namespace piezo::model::detail
