#pragma once
/// @file
/// The LuGre motor by Taylor series between events: the series mode of the
/// event-driven hybrid integrator (issue 23).
///
/// Between two events (a corner of the drive, a zero of the sliding
/// velocity v) s = sgn(v) is constant and the right-hand side is a
/// polynomial whose only nonlinear term is v*z:
///   z' = v - s*kappa*v*z,  F_f = sigma0 z + sigma1 z' + sigma2 v,
///   x'' = (K d_e V(t) - C x' - K x - F_f)/M,  theta'' = r F_f / J,
/// with kappa = sigma0/F_c and V(t) linear on each piece of the drive. The
/// series of every state comes from the usual recurrence (one Cauchy
/// product of v and z per order). The step is chosen from the decay of the
/// last two orders' coefficients against a scale per state and capped at
/// 4/omega_n, so that each half step holds at most one extremum of v. Zeros
/// of v are found on the series (a sign change at h/2 or h, or a dip whose
/// minimum crosses), refined by Newton, and the step ends at the root with
/// the new s = sgn(v') there (v is not reset to 0). Samples come from the
/// series. Allocation-free per step.
///
/// Not yet here (the rest of the hybrid): the closed-form finish of a
/// saturating bristle, the exact linear mode and the implicit stick mode;
/// in their phases this mode takes short steps (the bristle's rate
/// kappa*|v| bounds them).

#include <span>

#include "piezo/model/parameters.hpp"
#include "piezo/model/simulate.hpp"
#include "piezo/model/waveform.hpp"

namespace piezo::model {

/// Simulates the LuGre motor from rest by series (tolerance: the error per
/// step relative to each state's scale, as for DOPRI5's).
[[nodiscard]] Trajectory simulate_lugre_taylor(const MotorParameters& p, const Excitation& drive,
                                               std::span<const double> sample_times,
                                               const IntegratorSettings& settings);

}  // namespace piezo::model
