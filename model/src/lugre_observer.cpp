#include "piezo/model/lugre_observer.hpp"

#include <algorithm>

namespace piezo::model {

LuGreObserver::LuGreObserver(const MotorParameters& p, const ObserverGains& gains, double ramp_time,
                             double t0, const LuGreState& initial)
    : p_(p),
      motor_(p),
      gains_(gains),
      ramp_time_(ramp_time),
      integrator_(p),
      t_(t0),
      t_command_(t0) {
  integrator_.reset(t0, initial);
}

void LuGreObserver::advance_to(double t) {
  if (t <= t_) return;
  const double ramp_end = t_command_ + ramp_time_;
  if (t_ < ramp_end) {
    const double slope = (V_to_ - V_from_) / ramp_time_;
    const double until = std::min(t, ramp_end);
    integrator_.advance(LinearPiece{t_command_, V_from_, slope}, until);
    t_ = until;
  }
  if (t > t_) {
    integrator_.advance(LinearPiece{t_, V_to_, 0.0}, t);
    t_ = t;
  }
}

void LuGreObserver::command(double t, double V) {
  advance_to(t);
  // Continue from wherever the previous ramp had got to.
  const double progress = std::clamp((t - t_command_) / ramp_time_, 0.0, 1.0);
  V_from_ = V_from_ + (V_to_ - V_from_) * progress;
  V_to_ = V;
  t_command_ = t;
}

void LuGreObserver::restart(double t, const LuGreState& y, double V) {
  integrator_.reset(t, y);
  t_ = t;
  t_command_ = t;
  V_from_ = V_to_ = V;
  t_last_measurement_ = -1.0;
}

double LuGreObserver::measure(double t, double theta) {
  advance_to(t);
  LuGreState y = integrator_.state();
  const double residual = theta - y[kTheta];
  const double interval = t_last_measurement_ < 0.0 ? 0.0 : t - t_last_measurement_;
  t_last_measurement_ = t;
  y[kTheta] += gains_.alpha * residual;
  if (interval > 0.0) y[kThetaDot] += gains_.beta * residual / interval;
  integrator_.reset(t, y);
  return residual;
}

}  // namespace piezo::model
