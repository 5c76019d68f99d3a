#pragma once
// Plain fixed-step classical RK4 solutions of the motor models: the
// independent reference that the adaptive integrator is proven against, and
// the baseline of the simulation benchmark. Deliberately simple: no error
// control, no scaling; the Coulomb variant locates stick/slip switches by
// bisection with shortened RK4 steps, so its only approximation is the step.

#include <array>
#include <cmath>
#include <utility>

#include "piezo/model/motor.hpp"
#include "piezo/model/waveform.hpp"

namespace piezo::testing {

template <std::size_t N, class Rhs>
std::array<double, N> rk4_step(Rhs&& rhs, const std::array<double, N>& y, double t, double h) {
  std::array<double, N> k1, k2, k3, k4, tmp;
  rhs(y, k1, t);
  for (std::size_t i = 0; i < N; ++i) tmp[i] = y[i] + 0.5 * h * k1[i];
  rhs(tmp, k2, t + 0.5 * h);
  for (std::size_t i = 0; i < N; ++i) tmp[i] = y[i] + 0.5 * h * k2[i];
  rhs(tmp, k3, t + 0.5 * h);
  for (std::size_t i = 0; i < N; ++i) tmp[i] = y[i] + h * k3[i];
  rhs(tmp, k4, t + h);
  std::array<double, N> out;
  for (std::size_t i = 0; i < N; ++i)
    out[i] = y[i] + h / 6.0 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]);
  return out;
}

/// Rotor angle at t_end of the LuGre model, fixed step h from rest.
inline double lugre_rk4_angle(const model::MotorParameters& p, const model::Excitation& drive,
                              double t_end, double h) {
  const model::LuGreMotor motor(p);
  auto rhs = [&](const model::LuGreState& y, model::LuGreState& dy, double t) {
    motor.derivative(drive.voltage(t), y, dy);
  };
  model::LuGreState y{};
  const auto n = static_cast<long>(std::llround(t_end / h));
  for (long i = 0; i < n; ++i) y = rk4_step<5>(rhs, y, static_cast<double>(i) * h, h);
  return y[model::kTheta];
}

/// Rotor angle at t_end of the Coulomb (Karnopp) model, fixed step h from rest.
inline double coulomb_rk4_angle(const model::MotorParameters& p, const model::Excitation& drive,
                                double t_end, double h) {
  using model::ContactMode;
  ContactMode mode = ContactMode::stick;
  auto rhs = [&](const model::CoulombState& y, model::CoulombState& dy, double t) {
    model::coulomb_derivative(p, drive.voltage(t), mode, y, dy);
  };
  auto leaves_mode = [&](const model::CoulombState& y, double t) {
    if (mode == ContactMode::stick) {
      return std::abs(model::coulomb_stick_force(p, drive.voltage(t), y)) > p.F_c();
    }
    const double dir = mode == ContactMode::slip_forward ? 1.0 : -1.0;
    return dir * model::sliding_velocity(p, y) <= 0.0;
  };
  model::CoulombState y{};
  double t = 0.0;
  while (t < t_end - 1e-12) {
    const double h_step = std::min(h, t_end - t);
    model::CoulombState next = rk4_step<4>(rhs, y, t, h_step);
    if (!leaves_mode(next, t + h_step)) {
      y = next;
      t += h_step;
      continue;
    }
    double lo = 0.0, hi = h_step;
    for (int i = 0; i < 50 && hi - lo > 1e-15; ++i) {
      const double mid = 0.5 * (lo + hi);
      (leaves_mode(rk4_step<4>(rhs, y, t, mid), t + mid) ? hi : lo) = mid;
    }
    y = rk4_step<4>(rhs, y, t, hi);
    t += hi;
    const double F_hold = model::coulomb_stick_force(p, drive.voltage(t), y);
    if (mode != ContactMode::stick && std::abs(F_hold) <= p.F_c()) {
      mode = ContactMode::stick;
      y[model::kThetaDot] = y[model::kXDot] / p.r;
    } else {
      mode = F_hold > 0 ? ContactMode::slip_forward : ContactMode::slip_backward;
    }
  }
  return y[model::kTheta];
}

}  // namespace piezo::testing
