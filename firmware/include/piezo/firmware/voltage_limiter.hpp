#pragma once
/// @file
/// The drive's voltage and slew limits, applied to every command before it
/// reaches the hardware.

#include <algorithm>

namespace piezo::firmware {

struct VoltageLimits {
  double V_min = 0.0;         ///< [V] at the amplifier output
  double V_max = 0.0;         ///< [V]
  double slew_V_per_s = 0.0;  ///< largest |dV/dt| commanded
};

/// Moves from `previous` towards `target` by at most rate * dt.
[[nodiscard]] inline double step_towards(double previous, double target, double rate, double dt) {
  const double max_step = rate * dt;
  return std::clamp(target, previous - max_step, previous + max_step);
}

/// The next command: `target` clamped to the range, then slew-limited.
[[nodiscard]] inline double limit_voltage(const VoltageLimits& limits, double target,
                                          double previous, double dt) {
  return step_towards(previous, std::clamp(target, limits.V_min, limits.V_max), limits.slew_V_per_s,
                      dt);
}

}  // namespace piezo::firmware
