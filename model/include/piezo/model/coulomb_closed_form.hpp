#pragma once
/// @file
/// The Coulomb (Karnopp) motor solved in closed form between events. In each
/// contact mode the motor is linear with a piecewise-linear input: the
/// stator is a damped oscillator driven by a ramp plus a constant friction
/// force (slip) or carries the rotor's reflected mass (stick), and the rotor
/// either turns with it or under a constant torque. So between a drive
/// corner and the next stick/slip switch the state is an exact function of
/// time; the only numerical work is finding the switches, each bracketed by
/// a proof that no earlier one exists and then solved to full precision.

#include <span>

#include "piezo/model/parameters.hpp"
#include "piezo/model/simulate.hpp"
#include "piezo/model/waveform.hpp"

namespace piezo::model {

/// True when the stator rings (is underdamped) both alone and carrying the
/// rotor: the closed form below is written for that case, which holds for
/// any physical stack (critical damping needs C near 2 sqrt(K M), 1.5 kN s/m
/// at the paper's values).
[[nodiscard]] bool coulomb_closed_form_applies(const MotorParameters& p);

/// Same contract as simulate() for FrictionModel::coulomb; throws
/// std::invalid_argument when coulomb_closed_form_applies(p) is false.
[[nodiscard]] Trajectory simulate_coulomb_closed_form(const MotorParameters& p,
                                                      const Excitation& drive,
                                                      std::span<const double> times,
                                                      const IntegratorSettings& settings,
                                                      Trajectory storage = {});

}  // namespace piezo::model
