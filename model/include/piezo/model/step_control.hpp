#pragma once
/// @file
/// The accuracy and stability settings every integrator of the motor shares:
/// per-component absolute tolerances and the stability-bound step cap.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>

#include "piezo/model/motor.hpp"

namespace piezo::model {

/// Natural size of each state component. The states span ten orders of
/// magnitude (z ~ 1e-7 m, theta ~ 1e-2 rad), so each gets its own absolute
/// tolerance: the tolerance times this size. Sizes are the stack stroke at
/// 100 V, that stroke per millisecond, and the bristle deflection at sliding.
template <std::size_t N>
[[nodiscard]] std::array<double, N> state_scale(const MotorParameters& p) {
  const double stroke = std::max(p.d_e * 100.0, 1e-12);
  const double speed = stroke / 1e-3;
  std::array<double, N> s{};
  s[kX] = stroke;
  s[kXDot] = speed;
  s[kTheta] = stroke / p.r;
  s[kThetaDot] = speed / p.r;
  if constexpr (N > 4) s[kZ] = p.F_c() / p.sigma0;
  return s;
}

/// Explicit Runge-Kutta steps beyond the stability limit on the stator's
/// lightly damped oscillation (omega_n * h ~ 3) are rejected anyway; capping
/// the step at 2/omega_n avoids those rejections.
[[nodiscard]] inline double max_stable_step(const MotorParameters& p) {
  return 2.0 / std::sqrt(p.K / p.M);
}

}  // namespace piezo::model
