#include "piezo/model/travel_targets.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "log_space_fit.hpp"
#include "piezo/model/waveform.hpp"

namespace piezo::model {
namespace {

/// A target the model misses by this much (3x its time) counts as not
/// reached: the residual goes on growing with the angle still to cover, so
/// the fit is pulled back rather than stuck on a flat penalty.
constexpr double kHorizon = 3.0;

/// The Jacobian's step in log space: 0.1 % of each parameter, as for a log.
constexpr double kTravelDifferenceStep = 1e-3;

}  // namespace

double travel_time(const Parameters& p, double angle_rad, FrictionModel model, double t_max_s,
                   double tolerance) {
  const Sawtooth drive(p.drive.V0, p.drive.f, p.drive.rise());
  // The angle at each period's end, the drive back at 0 V: within a period
  // the rotor sticks forward and slips back, so the first time its angle
  // reaches a level jumps by a whole period when a peak just misses it; at
  // the periods' ends it only grows, and the crossing between two of them
  // moves smoothly with the parameters (and is where a position is read).
  const auto times = uniform_times(t_max_s, 1.0 / p.drive.f);
  const Trajectory tr = simulate(p.motor, drive, model, times, {.tolerance = tolerance});
  const double sign = angle_rad < 0.0 ? -1.0 : 1.0;
  const double target = std::abs(angle_rad);
  for (std::size_t i = 1; i < tr.size(); ++i) {
    const double a = sign * tr.theta[i - 1], b = sign * tr.theta[i];
    if (b >= target) {
      return b == a ? tr.t[i] : tr.t[i - 1] + (target - a) * (tr.t[i] - tr.t[i - 1]) / (b - a);
    }
  }
  return std::numeric_limits<double>::quiet_NaN();
}

Parameters with_settings(const Parameters& start, const TravelTarget& target) {
  Parameters p = start;
  for (const auto& [name, value] : target.settings) {
    const ParameterSpec* s = find_parameter(name);
    if (s == nullptr) throw std::invalid_argument("target: unknown parameter '" + name + "'");
    if (!s->admits(value)) {
      throw std::invalid_argument("target: " + name + " = " + std::to_string(value) +
                                  " is outside " + s->range_text());
    }
    s->ref(p) = value;
  }
  return p;
}

TargetFitResult fit_travel_targets(const Parameters& start,
                                   const std::vector<TravelTarget>& targets,
                                   const FitSettings& settings) {
  if (settings.free.empty()) throw std::invalid_argument("targets: no parameter to fit");
  if (targets.size() < settings.free.size()) {
    throw std::invalid_argument("targets: " + std::to_string(targets.size()) +
                                " targets cannot fix " + std::to_string(settings.free.size()) +
                                " free parameters; free at most as many as there are targets");
  }
  for (const auto& t : targets) {
    if (!(t.time_s > 0.0) || !(t.angle_rad != 0.0) || !std::isfinite(t.angle_rad)) {
      throw std::invalid_argument("targets: each needs an angle other than 0 and a time above 0");
    }
    (void)with_settings(start, t);  // its settings are known symbols in range
  }
  // Each unknown: a shared one (target 0) or one target's own ("d_e@2": target 2's).
  std::vector<detail::Unknown> unknowns;
  std::vector<std::size_t> owner;  // 0: every target; k: target k only (1-based)
  for (const auto& name : settings.free) {
    // Named, not bound: a lambda below may not capture a structured binding (clang).
    const auto split = split_free_name(name, targets.size());
    const std::string& base = split.first;
    const std::size_t k = split.second;
    const Parameters& at = k == 0 ? start : with_settings(start, targets[k - 1]);
    const ParameterSpec* s = detail::free_spec(at, base, settings.model, "targets");
    if (k > 0 && std::any_of(targets[k - 1].settings.begin(), targets[k - 1].settings.end(),
                             [&](const auto& kv) { return kv.first == base; })) {
      throw std::invalid_argument("targets: " + name + ": target " + std::to_string(k) + " sets " +
                                  base + " itself; free it or set it, not both");
    }
    unknowns.push_back({s, name, *get_parameter(at, base)});
    owner.push_back(k);
  }
  // Target i's parameters: the shared values, its own settings, its own values.
  const auto parameters_for = [&](const std::vector<double>& values, std::size_t i) {
    Parameters p = start;
    for (std::size_t u = 0; u < unknowns.size(); ++u) {
      if (owner[u] == 0) unknowns[u].spec->ref(p) = values[u];
    }
    p = with_settings(p, targets[i]);
    for (std::size_t u = 0; u < unknowns.size(); ++u) {
      if (owner[u] == i + 1) unknowns[u].spec->ref(p) = values[u];
    }
    return p;
  };
  const auto outcome = [&](const Parameters& q, const TravelTarget& t) {
    const double time =
        travel_time(q, t.angle_rad, settings.model, kHorizon * t.time_s, settings.tolerance);
    return TargetOutcome{time, time / t.time_s - 1.0};
  };
  // The log of the model's time over the target's: the same weight for a
  // 5 s and a 1 s target, and symmetric in too fast and too slow.
  const auto residual = [&](const Parameters& q, const TravelTarget& t) {
    const double time = outcome(q, t).model_time_s;
    if (std::isfinite(time)) return std::log(time / t.time_s);
    // Not reached: beyond the horizon, by the share of the angle still to cover.
    const double end =
        final_angle(q.motor, Sawtooth(q.drive.V0, q.drive.f, q.drive.rise()), settings.model,
                    kHorizon * t.time_s, {.tolerance = settings.tolerance});
    return std::log(kHorizon) + std::max(0.0, 1.0 - end / t.angle_rad);
  };
  const auto residuals = [&](const std::vector<double>& values, Eigen::VectorXd& r) {
    for (std::size_t i = 0; i < targets.size(); ++i) {
      r[static_cast<Eigen::Index>(i)] = residual(parameters_for(values, i), targets[i]);
    }
  };
  const detail::LogSpaceFit fit = detail::fit_in_log_space(
      unknowns, static_cast<int>(targets.size()), residuals, settings, kTravelDifferenceStep);
  TargetFitResult result;
  result.fit.parameters = start;
  for (std::size_t u = 0; u < unknowns.size(); ++u) {
    if (owner[u] == 0) unknowns[u].spec->ref(result.fit.parameters) = fit.values[u];
  }
  result.fit.iterations = fit.iterations;
  result.fit.converged = fit.converged;
  result.fit.stop_reason = fit.stop_reason;
  result.fit.fitted = detail::fitted_parameters(unknowns, fit);
  result.fit.notes = detail::fit_notes(unknowns, fit);
  if (fit.covariance.size() == 0) {
    result.fit.notes.push_back(
        "as many targets as free parameters: the fit meets them exactly or not at all, and "
        "has no intervals");
  }
  std::vector<double> initial;
  for (const auto& u : unknowns) initial.push_back(u.start);
  for (std::size_t i = 0; i < targets.size(); ++i) {
    result.initial_targets.push_back(outcome(parameters_for(initial, i), targets[i]));
    result.targets.push_back(outcome(parameters_for(fit.values, i), targets[i]));
  }
  return result;
}

}  // namespace piezo::model
