#include "piezo/model/identify.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <unsupported/Eigen/LevenbergMarquardt>

#include "piezo/model/sampled_drive.hpp"

namespace piezo::model {
namespace {

constexpr double kDifferenceStep = 1e-3;  // in log space: 0.1 % of each parameter
constexpr double kZ95 = 1.959964;

struct AngleResiduals : Eigen::DenseFunctor<double> {
  AngleResiduals(const Parameters& start, const FitData& data, const FitSettings& settings,
                 std::vector<const ParameterSpec*> specs)
      : DenseFunctor(static_cast<int>(specs.size()), static_cast<int>(data.t.size())),
        start_(start),
        data_(data),
        settings_(settings),
        specs_(std::move(specs)) {}

  [[nodiscard]] Parameters at(const Eigen::VectorXd& u) const {
    Parameters p = start_;
    for (std::size_t i = 0; i < specs_.size(); ++i) {
      const ParameterSpec& s = *specs_[i];
      double v = std::exp(u[static_cast<Eigen::Index>(i)]);
      // Keep to the allowed range (open ends nudged inside).
      v = std::clamp(v, s.min_inclusive ? s.min : std::nextafter(s.min, s.max),
                     s.max_inclusive ? s.max : std::nextafter(s.max, s.min));
      s.ref(p) = v;
    }
    return p;
  }

  void residuals(const Eigen::VectorXd& u, Eigen::VectorXd& r) const {
    const auto theta =
        predict(at(u), data_, settings_.model, settings_.tolerance, settings_.within_simulation);
    for (std::size_t i = 0; i < theta.size(); ++i) {
      r[static_cast<Eigen::Index>(i)] = theta[i] - data_.theta[i];
    }
  }

  int operator()(const Eigen::VectorXd& u, Eigen::VectorXd& r) const {
    residuals(u, r);
    return 0;
  }

  // Central differences, one column per job (the columns are independent runs).
  int df(const Eigen::VectorXd& u, Eigen::MatrixXd& jacobian) const {
    const auto n = static_cast<std::size_t>(u.size());
    settings_.for_each(n, [&](std::size_t j) {
      Eigen::VectorXd up = u, down = u;
      up[static_cast<Eigen::Index>(j)] += kDifferenceStep;
      down[static_cast<Eigen::Index>(j)] -= kDifferenceStep;
      Eigen::VectorXd r_up(values()), r_down(values());
      residuals(up, r_up);
      residuals(down, r_down);
      jacobian.col(static_cast<Eigen::Index>(j)) = (r_up - r_down) / (2 * kDifferenceStep);
    });
    return 0;
  }

 private:
  Parameters start_;
  const FitData& data_;
  const FitSettings& settings_;
  std::vector<const ParameterSpec*> specs_;
};

double rms(const Eigen::VectorXd& r) {
  return std::sqrt(r.squaredNorm() / static_cast<double>(r.size()));
}

std::vector<std::string> identifiability_notes(const std::vector<const ParameterSpec*>& specs,
                                               const Eigen::MatrixXd& correlation) {
  std::vector<std::string> notes;
  auto has = [&](std::string_view n) {
    return std::any_of(specs.begin(), specs.end(), [&](auto* s) { return s->name == n; });
  };
  if (has("mu") && has("F_N")) {
    notes.push_back(
        "mu and F_N enter the model only as their product F_c = mu*F_N: they are "
        "not separately identifiable; fit one of them");
  }
  for (Eigen::Index i = 0; i < correlation.rows(); ++i) {
    for (Eigen::Index j = i + 1; j < correlation.cols(); ++j) {
      if (std::abs(correlation(i, j)) > 0.99) {
        notes.push_back(std::string(specs[static_cast<std::size_t>(i)]->name) + " and " +
                        std::string(specs[static_cast<std::size_t>(j)]->name) +
                        " are strongly correlated in this data (|r| > 0.99): the data cannot "
                        "tell them apart well");
      }
    }
  }
  return notes;
}

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
  if (data.t.size() < settings.free.size() + 2 || data.t.size() != data.theta.size()) {
    throw std::invalid_argument("identify: too few measurements");
  }
  std::vector<const ParameterSpec*> specs;
  for (const auto& name : settings.free) {
    const ParameterSpec* s = find_parameter(name);
    if (s == nullptr) throw std::invalid_argument("identify: unknown parameter '" + name + "'");
    if (!model_uses(settings.model, name)) {
      throw std::invalid_argument("identify: the model does not use '" + name + "'");
    }
    if (!(s->min >= 0.0) || !(get_parameter(start, name).value() > 0.0)) {
      throw std::invalid_argument("identify: '" + name + "' must be positive to be fitted");
    }
    specs.push_back(s);
  }
  AngleResiduals f(start, data, settings, specs);
  Eigen::VectorXd u(static_cast<Eigen::Index>(specs.size()));
  for (std::size_t i = 0; i < specs.size(); ++i) {
    u[static_cast<Eigen::Index>(i)] = std::log(*get_parameter(start, specs[i]->name));
  }

  FitResult result;
  Eigen::VectorXd r(f.values());
  f(u, r);
  result.initial_rmse_rad = rms(r);

  Eigen::LevenbergMarquardt<AngleResiduals> lm(f);
  lm.setXtol(1e-8);
  lm.setFtol(1e-10);
  auto status = lm.minimizeInit(u);
  if (status == Eigen::LevenbergMarquardtSpace::ImproperInputParameters) {
    throw std::invalid_argument("identify: improper input to Levenberg-Marquardt");
  }
  do {
    status = lm.minimizeOneStep(u);
    ++result.iterations;
    f(u, r);
    settings.progress(result.iterations, rms(r));
  } while (status == Eigen::LevenbergMarquardtSpace::Running &&
           result.iterations < settings.max_iterations);

  using Status = Eigen::LevenbergMarquardtSpace::Status;
  switch (status) {
    case Status::RelativeReductionTooSmall:
    case Status::RelativeErrorTooSmall:
    case Status::RelativeErrorAndReductionTooSmall:
    case Status::CosinusTooSmall:
      result.converged = true;
      result.stop_reason = "converged";
      break;
    case Status::FtolTooSmall:
    case Status::XtolTooSmall:
    case Status::GtolTooSmall:
      // No step can improve the fit at the tolerances asked: an optimum as
      // far as the residual can tell.
      result.converged = true;
      result.stop_reason = "converged (no further improvement at these tolerances)";
      break;
    case Status::Running:
      result.stop_reason = "stopped at max_iterations = " + std::to_string(settings.max_iterations);
      break;
    case Status::TooManyFunctionEvaluation:
      result.stop_reason = "stopped after too many evaluations of the model";
      break;
    default:
      result.stop_reason =
          "stopped: Levenberg-Marquardt status " + std::to_string(static_cast<int>(status));
      break;
  }
  result.parameters = f.at(u);
  f(u, r);
  result.rmse_rad = rms(r);
  result.theta_fit = predict(result.parameters, data, settings.model, settings.tolerance);

  // Covariance in log space: s^2 (J^T J)^-1, s^2 = RSS / (n - p).
  Eigen::MatrixXd jacobian(f.values(), f.inputs());
  f.df(u, jacobian);
  const double dof = static_cast<double>(f.values() - f.inputs());
  const Eigen::MatrixXd covariance =
      (r.squaredNorm() / dof) *
      (jacobian.transpose() * jacobian).completeOrthogonalDecomposition().pseudoInverse();
  Eigen::MatrixXd correlation = covariance;
  for (Eigen::Index i = 0; i < covariance.rows(); ++i) {
    for (Eigen::Index j = 0; j < covariance.cols(); ++j) {
      correlation(i, j) = covariance(i, j) / std::sqrt(covariance(i, i) * covariance(j, j));
    }
  }
  for (std::size_t i = 0; i < specs.size(); ++i) {
    const auto k = static_cast<Eigen::Index>(i);
    const double value = *get_parameter(result.parameters, specs[i]->name);
    const double sigma_log = std::sqrt(std::max(covariance(k, k), 0.0));
    result.fitted.push_back({std::string(specs[i]->name), value, value * sigma_log,
                             value * std::exp(-kZ95 * sigma_log),
                             value * std::exp(kZ95 * sigma_log)});
  }
  result.notes = identifiability_notes(specs, correlation);
  if (!result.converged) {
    result.notes.insert(result.notes.begin(),
                        "not converged (" + result.stop_reason +
                            "): the values are where the fit stopped, and their standard errors "
                            "and 95 % intervals, which assume an optimum, mean nothing");
  }
  return result;
}

}  // namespace piezo::model
