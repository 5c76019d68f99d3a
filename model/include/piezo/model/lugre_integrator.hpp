#pragma once
/// @file
/// The LuGre motor advanced piece by piece as its input arrives: the
/// simulated plant and the observer do not know the drive in advance, so
/// they integrate over each linear piece of voltage once it is known.

#include "piezo/model/dopri5.hpp"
#include "piezo/model/motor.hpp"
#include "piezo/model/step_control.hpp"
#include "piezo/model/waveform.hpp"

namespace piezo::model {

/// Adaptive Dormand-Prince integration of the LuGre motor from a given state.
/// Allocation-free: safe to call from a real-time loop.
class LuGreIntegrator {
 public:
  explicit LuGreIntegrator(const MotorParameters& p, double tolerance = 1e-6)
      : motor_(p), stepper_(tolerance, scaled_atol(p, tolerance), max_stable_step(p)) {}

  /// Restarts at time t in state y.
  void reset(double t, const LuGreState& y) {
    t_ = t;
    y_ = y;
  }

  /// Advances to t_end with the voltage following `piece` (a ramp or a
  /// constant). Every call restarts the stepper, so the piece may jump.
  void advance(const LinearPiece& piece, double t_end) {
    if (t_end <= t_) return;
    auto rhs = [&](const LuGreState& y, LuGreState& dydt, double t) {
      motor_.derivative(piece.at(t), y, dydt);
    };
    stepper_.initialize(rhs, t_, y_, std::min(h_, t_end - t_));
    const double at_end = 1e-13 * std::max(1.0, t_end);
    while (t_end - stepper_.time() > at_end) stepper_.step(rhs, t_end - stepper_.time());
    h_ = stepper_.proposed_step();
    y_ = stepper_.state();
    t_ = t_end;
  }

  [[nodiscard]] const LuGreState& state() const { return y_; }
  [[nodiscard]] double time() const { return t_; }

 private:
  static LuGreState scaled_atol(const MotorParameters& p, double tolerance) {
    LuGreState atol = state_scale<5>(p);
    for (double& a : atol) a *= tolerance;
    return atol;
  }

  LuGreMotor motor_;
  Dopri5<5> stepper_;
  double t_ = 0.0;
  double h_ = 1e-7;
  LuGreState y_{};
};

}  // namespace piezo::model
