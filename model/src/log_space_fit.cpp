#include "log_space_fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <unsupported/Eigen/LevenbergMarquardt>

namespace piezo::model::detail {
namespace {

constexpr double kZ95 = 1.959964;

struct Residuals : Eigen::DenseFunctor<double> {
  Residuals(const std::vector<Unknown>& unknowns, int count,
            const std::function<void(const std::vector<double>&, Eigen::VectorXd&)>& residuals,
            const FitSettings& settings, double difference_step)
      : DenseFunctor(static_cast<int>(unknowns.size()), count),
        step_(difference_step),
        unknowns_(unknowns),
        residuals_(residuals),
        settings_(settings) {}

  /// The values at log-space point u, each kept to its parameter's range
  /// (open ends nudged inside).
  [[nodiscard]] std::vector<double> at(const Eigen::VectorXd& u) const {
    std::vector<double> values(unknowns_.size());
    for (std::size_t i = 0; i < unknowns_.size(); ++i) {
      const ParameterSpec& s = *unknowns_[i].spec;
      values[i] = std::clamp(std::exp(u[static_cast<Eigen::Index>(i)]),
                             s.min_inclusive ? s.min : std::nextafter(s.min, s.max),
                             s.max_inclusive ? s.max : std::nextafter(s.max, s.min));
    }
    return values;
  }

  int operator()(const Eigen::VectorXd& u, Eigen::VectorXd& r) const {
    residuals_(at(u), r);
    return 0;
  }

  // Central differences, one column per job (the columns are independent runs).
  int df(const Eigen::VectorXd& u, Eigen::MatrixXd& jacobian) const {
    const auto n = static_cast<std::size_t>(u.size());
    settings_.for_each(n, [&](std::size_t j) {
      Eigen::VectorXd up = u, down = u;
      up[static_cast<Eigen::Index>(j)] += step_;
      down[static_cast<Eigen::Index>(j)] -= step_;
      Eigen::VectorXd r_up(values()), r_down(values());
      (*this)(up, r_up);
      (*this)(down, r_down);
      jacobian.col(static_cast<Eigen::Index>(j)) = (r_up - r_down) / (2 * step_);
    });
    return 0;
  }

 private:
  double step_;
  const std::vector<Unknown>& unknowns_;
  const std::function<void(const std::vector<double>&, Eigen::VectorXd&)>& residuals_;
  const FitSettings& settings_;
};

}  // namespace

double rms(const Eigen::VectorXd& r) {
  return std::sqrt(r.squaredNorm() / static_cast<double>(r.size()));
}

const ParameterSpec* free_spec(const Parameters& start, const std::string& name,
                               FrictionModel model, const std::string& who) {
  const ParameterSpec* s = find_parameter(name);
  if (s == nullptr) throw std::invalid_argument(who + ": unknown parameter '" + name + "'");
  if (!model_uses(model, name)) {
    throw std::invalid_argument(who + ": the model does not use '" + name + "'");
  }
  if (!(s->min >= 0.0) || !(get_parameter(start, name).value() > 0.0)) {
    throw std::invalid_argument(who + ": '" + name + "' must be positive to be fitted");
  }
  return s;
}

LogSpaceFit fit_in_log_space(
    const std::vector<Unknown>& unknowns, int count,
    const std::function<void(const std::vector<double>&, Eigen::VectorXd&)>& residuals,
    const FitSettings& settings, double difference_step) {
  if (unknowns.empty()) throw std::invalid_argument("no parameter to fit");
  Residuals f(unknowns, count, residuals, settings, difference_step);
  Eigen::VectorXd u(static_cast<Eigen::Index>(unknowns.size()));
  for (std::size_t i = 0; i < unknowns.size(); ++i) {
    u[static_cast<Eigen::Index>(i)] = std::log(unknowns[i].start);
  }
  LogSpaceFit out;
  out.initial_residuals.resize(f.values());
  f(u, out.initial_residuals);

  Eigen::LevenbergMarquardt<Residuals> lm(f);
  lm.setXtol(1e-8);
  lm.setFtol(1e-10);
  auto status = lm.minimizeInit(u);
  if (status == Eigen::LevenbergMarquardtSpace::ImproperInputParameters) {
    throw std::invalid_argument("improper input to Levenberg-Marquardt");
  }
  Eigen::VectorXd r(f.values());
  do {
    status = lm.minimizeOneStep(u);
    ++out.iterations;
    f(u, r);
    settings.progress(out.iterations, rms(r));
  } while (status == Eigen::LevenbergMarquardtSpace::Running &&
           out.iterations < settings.max_iterations);

  using Status = Eigen::LevenbergMarquardtSpace::Status;
  switch (status) {
    case Status::RelativeReductionTooSmall:
    case Status::RelativeErrorTooSmall:
    case Status::RelativeErrorAndReductionTooSmall:
    case Status::CosinusTooSmall:
      out.converged = true;
      out.stop_reason = "converged";
      break;
    case Status::FtolTooSmall:
    case Status::XtolTooSmall:
    case Status::GtolTooSmall:
      // No step can improve the fit at the tolerances asked: an optimum as
      // far as the residual can tell.
      out.converged = true;
      out.stop_reason = "converged (no further improvement at these tolerances)";
      break;
    case Status::Running:
      out.stop_reason = "stopped at max_iterations = " + std::to_string(settings.max_iterations);
      break;
    case Status::TooManyFunctionEvaluation:
      out.stop_reason = "stopped after too many evaluations of the model";
      break;
    default:
      out.stop_reason =
          "stopped: Levenberg-Marquardt status " + std::to_string(static_cast<int>(status));
      break;
  }
  out.values = f.at(u);
  f(u, r);
  out.residuals = r;

  // Covariance in log space: s^2 (J^T J)^-1, s^2 = RSS / (n - p); none
  // without degrees of freedom (as many values as parameters: an exact fit).
  const auto dof = f.values() - f.inputs();
  if (dof > 0) {
    Eigen::MatrixXd jacobian(f.values(), f.inputs());
    f.df(u, jacobian);
    out.covariance =
        (r.squaredNorm() / static_cast<double>(dof)) *
        (jacobian.transpose() * jacobian).completeOrthogonalDecomposition().pseudoInverse();
    out.correlation = out.covariance;
    for (Eigen::Index i = 0; i < out.covariance.rows(); ++i) {
      for (Eigen::Index j = 0; j < out.covariance.cols(); ++j) {
        out.correlation(i, j) =
            out.covariance(i, j) / std::sqrt(out.covariance(i, i) * out.covariance(j, j));
      }
    }
  }
  return out;
}

std::vector<FittedParameter> fitted_parameters(const std::vector<Unknown>& unknowns,
                                               const LogSpaceFit& fit) {
  std::vector<FittedParameter> out;
  constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t i = 0; i < unknowns.size(); ++i) {
    const auto k = static_cast<Eigen::Index>(i);
    const double value = fit.values[i];
    if (fit.covariance.size() == 0) {
      out.push_back({unknowns[i].name, value, kNone, kNone, kNone});
      continue;
    }
    const double sigma_log = std::sqrt(std::max(fit.covariance(k, k), 0.0));
    out.push_back({unknowns[i].name, value, value * sigma_log, value * std::exp(-kZ95 * sigma_log),
                   value * std::exp(kZ95 * sigma_log)});
  }
  return out;
}

std::vector<std::string> fit_notes(const std::vector<Unknown>& unknowns, const LogSpaceFit& fit) {
  std::vector<std::string> notes;
  auto has = [&](std::string_view n) {
    return std::any_of(unknowns.begin(), unknowns.end(),
                       [&](const Unknown& u) { return u.spec->name == n; });
  };
  if (has("mu") && has("F_N")) {
    notes.push_back(
        "mu and F_N enter the model only as their product F_c = mu*F_N: they are "
        "not separately identifiable; fit one of them");
  }
  for (Eigen::Index i = 0; i < fit.correlation.rows(); ++i) {
    for (Eigen::Index j = i + 1; j < fit.correlation.cols(); ++j) {
      if (std::abs(fit.correlation(i, j)) > 0.99) {
        notes.push_back(unknowns[static_cast<std::size_t>(i)].name + " and " +
                        unknowns[static_cast<std::size_t>(j)].name +
                        " are strongly correlated in this data (|r| > 0.99): the data cannot "
                        "tell them apart well");
      }
    }
  }
  if (!fit.converged) {
    notes.insert(notes.begin(),
                 "not converged (" + fit.stop_reason +
                     "): the values are where the fit stopped, and their standard errors "
                     "and 95 % intervals, which assume an optimum, mean nothing");
  }
  return notes;
}

}  // namespace piezo::model::detail
