#pragma once
/// @file
/// The stator's free oscillation (its ~5.7 kHz ringing after a drive corner)
/// split from the smooth motion, for the hybrid integrator's mode guards.

#include <cmath>

#include "piezo/model/motor.hpp"
#include "piezo/model/parameters.hpp"

namespace piezo::model::hybrid {

struct Ringing {
  double amplitude;  ///< velocity amplitude of the stator's free oscillation [m/s]
  double smooth_v;   ///< the sliding velocity without it [m/s]
};

/// The stator follows the drive quasi-statically, x_p = d_e V - (F_f + C x_p')/K
/// with x_p' = d_e V', apart from its free oscillation around x_p, whose
/// velocity amplitude is sqrt(e'^2 + (K/M) e^2) with e = x - x_p.
[[nodiscard]] inline Ringing split_ringing(const MotorParameters& p, const LuGreState& y, double V,
                                           double slope, double F_f) {
  const double X_p = p.d_e * slope;
  const double x_p = p.d_e * V - (F_f + p.C * X_p) / p.K;
  const double e = y[kX] - x_p;
  const double e_dot = y[kXDot] - X_p;
  return {std::sqrt(e_dot * e_dot + p.K / p.M * e * e), X_p - p.r * y[kThetaDot]};
}

}  // namespace piezo::model::hybrid
