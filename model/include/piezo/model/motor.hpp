#pragma once
/// @file
/// Right-hand sides of the two motor models of docs/model.md section 2. Pure,
/// allocation-free functions: the integrators, the observer and the
/// simulated plant all evaluate these same equations.

#include <array>
#include <cmath>

#include "piezo/model/parameters.hpp"

namespace piezo::model {

/// LuGre state: x [m], x_dot [m/s], theta [rad], theta_dot [rad/s], z [m].
using LuGreState = std::array<double, 5>;
/// Coulomb state: x, x_dot, theta, theta_dot (no bristle state).
using CoulombState = std::array<double, 4>;

enum StateIndex : int { kX = 0, kXDot = 1, kTheta = 2, kThetaDot = 3, kZ = 4 };

/// Relative (sliding) velocity v = x' - r theta'.
template <std::size_t N>
[[nodiscard]] inline double sliding_velocity(const MotorParameters& p,
                                             const std::array<double, N>& y) {
  return y[kXDot] - p.r * y[kThetaDot];
}

/// LuGre friction force and bristle rate for state y.
struct LuGreFriction {
  double force;   ///< F_f [N]
  double z_rate;  ///< z' [m/s]
};

/// The LuGre equations with their constant ratios worked out once: the
/// integrators evaluate them millions of times per simulated run.
class LuGreMotor {
 public:
  explicit LuGreMotor(const MotorParameters& p)
      : p_(p),
        sigma0_over_Fc_(p.sigma0 / p.F_c()),
        inv_M_(1.0 / p.M),
        r_over_J_(p.r / p.J),
        K_d_e_(p.K * p.d_e) {}

  [[nodiscard]] LuGreFriction friction(const LuGreState& y) const {
    return friction(y[kXDot], y[kThetaDot], y[kZ]);
  }
  /// The same from the three states it depends on.
  [[nodiscard]] LuGreFriction friction(double x_dot, double theta_dot, double z) const {
    const double v = x_dot - p_.r * theta_dot;
    const double z_rate = v - sigma0_over_Fc_ * std::abs(v) * z;
    return {p_.sigma0 * z + p_.sigma1 * z_rate + p_.sigma2 * v, z_rate};
  }

  /// dy/dt at amplifier voltage V.
  void derivative(double V, const LuGreState& y, LuGreState& dydt) const {
    const LuGreFriction fr = friction(y);
    dydt[kX] = y[kXDot];
    dydt[kXDot] = (K_d_e_ * V - p_.C * y[kXDot] - p_.K * y[kX] - fr.force) * inv_M_;
    dydt[kTheta] = y[kThetaDot];
    dydt[kThetaDot] = r_over_J_ * fr.force;
    dydt[kZ] = fr.z_rate;
  }

 private:
  MotorParameters p_;
  double sigma0_over_Fc_, inv_M_, r_over_J_, K_d_e_;
};

/// Contact mode of the Coulomb (Karnopp) model.
enum class ContactMode { stick, slip_forward, slip_backward };

/// Friction force needed to keep rotor and stator locked together (stick).
[[nodiscard]] inline double coulomb_stick_force(const MotorParameters& p, double V,
                                                const CoulombState& y) {
  // Locked: x'' = r theta''; the rotor's inertia reflects to the contact as J/r^2.
  const double reflected_mass = p.J / (p.r * p.r);
  const double x_acc = (p.K * p.d_e * V - p.C * y[kXDot] - p.K * y[kX]) / (p.M + reflected_mass);
  return reflected_mass * x_acc;
}

/// Karnopp's rule where a slip ends (v = 0): stick if the holding force is
/// within F_c, otherwise slip the way that force points.
[[nodiscard]] inline ContactMode coulomb_mode_after_slip(const MotorParameters& p, double V,
                                                         const CoulombState& y) {
  const double hold = coulomb_stick_force(p, V, y);
  if (std::abs(hold) <= p.F_c()) return ContactMode::stick;
  return hold > 0.0 ? ContactMode::slip_forward : ContactMode::slip_backward;
}

/// Friction force of the Coulomb model in a given mode.
[[nodiscard]] inline double coulomb_friction(const MotorParameters& p, double V, ContactMode mode,
                                             const CoulombState& y) {
  switch (mode) {
    case ContactMode::stick:
      return coulomb_stick_force(p, V, y);
    case ContactMode::slip_forward:
      return p.F_c();
    case ContactMode::slip_backward:
      return -p.F_c();
  }
  return 0.0;
}

/// dy/dt of the Coulomb motor at voltage V in the given contact mode.
inline void coulomb_derivative(const MotorParameters& p, double V, ContactMode mode,
                               const CoulombState& y, CoulombState& dydt) {
  const double F_f = coulomb_friction(p, V, mode, y);
  dydt[kX] = y[kXDot];
  dydt[kXDot] = (p.K * p.d_e * V - p.C * y[kXDot] - p.K * y[kX] - F_f) / p.M;
  dydt[kTheta] = y[kThetaDot];
  dydt[kThetaDot] = p.r * F_f / p.J;
}

}  // namespace piezo::model
