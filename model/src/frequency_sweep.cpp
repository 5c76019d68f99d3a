#include "piezo/model/frequency_sweep.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "piezo/model/waveform.hpp"

namespace piezo::model {

StepMetrics period_metrics(const Parameters& p, FrictionModel model, const PeriodSettings& s,
                           const IntegratorSettings& integrator) {
  if (s.periods <= s.settle_periods || s.samples_per_period < 2) {
    throw std::invalid_argument("period_metrics: periods must exceed settle_periods");
  }
  const double T = 1.0 / p.drive.f;
  const double t_end = s.periods * T;
  std::vector<double> times;
  const int n = s.periods * s.samples_per_period;
  times.reserve(static_cast<std::size_t>(n) + 1);
  for (int i = 0; i <= n; ++i) times.push_back(t_end * i / n);
  const Sawtooth drive(p.drive.V0, p.drive.f, p.drive.D());
  const Trajectory tr = simulate(p.motor, drive, model, times, integrator);

  StepMetrics m;
  m.mean_velocity_rad_s = tr.theta.back() / t_end;
  m.integrator_steps = tr.stats.steps;
  const auto at = [&](int period) {
    return tr.theta[static_cast<std::size_t>(period * s.samples_per_period)];
  };
  const int measured = s.periods - s.settle_periods;
  m.step_rad = (at(s.periods) - at(s.settle_periods)) / measured;
  double backslip = 0.0;
  for (int k = s.settle_periods; k < s.periods; ++k) {
    const auto first = tr.theta.begin() + k * s.samples_per_period;
    const double peak = *std::max_element(first, first + s.samples_per_period + 1);
    backslip += peak - at(k + 1);
  }
  m.backslip_rad = backslip / measured;
  return m;
}

std::vector<double> sweep_values(double from, double to, int points, bool log) {
  if (points < 1) throw std::invalid_argument("sweep_values: points must be >= 1");
  if (log && !(from > 0.0 && to > 0.0)) {
    throw std::invalid_argument("sweep_values: a log sweep needs positive ends");
  }
  std::vector<double> out;
  for (int i = 0; i < points; ++i) {
    const double u = points == 1 ? 0.0 : static_cast<double>(i) / (points - 1);
    out.push_back(log ? from * std::pow(to / from, u) : from + (to - from) * u);
  }
  return out;
}

}  // namespace piezo::model
