#pragma once
/// @file
/// Stick mode of the LuGre hybrid integrator: while the bristle is far from
/// saturation and the stator's ringing has died away, the contact sticks and
/// the motor is stiff (the stator's 5.7 kHz mode beside the drive's ms).
/// A linearly implicit Rosenbrock method of order 4(3) (Hairer and Wanner's
/// RODAS4, L-stable, stiffly accurate), with the analytic Jacobian of the
/// motor at fixed sliding sign s and the drive's time derivative (without it
/// the steps collapse to microseconds on a ramp). Allocation-free.

#include <Eigen/Dense>

#include "piezo/model/motor.hpp"
#include "piezo/model/parameters.hpp"

namespace piezo::model::hybrid {

class StickRosenbrock {
 public:
  StickRosenbrock(const MotorParameters& p, const LuGreState& atol, double rtol);

  /// One step of h from y at drive voltage V (slope [V/s]) with the sliding
  /// sign s. Writes the new state and returns the error norm (<= 1: accept).
  [[nodiscard]] double step(const LuGreState& y, double V, double slope, double s, double h,
                            LuGreState& out) const;

  /// dy/dt at voltage V with the sliding sign s (|v| = s v).
  void derivative(const LuGreState& y, double V, double s, LuGreState& dydt) const;

 private:
  using Vector = Eigen::Matrix<double, 5, 1>;
  using Matrix = Eigen::Matrix<double, 5, 5>;
  [[nodiscard]] Vector f(const Vector& y, double V, double s) const;
  [[nodiscard]] Matrix jacobian(const Vector& y, double s) const;

  MotorParameters p_;
  double kappa_;
  Vector atol_;
  double rtol_;
};

}  // namespace piezo::model::hybrid
