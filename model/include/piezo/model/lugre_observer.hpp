#pragma once
/// @file
/// A LuGre observer with output injection: the motor model runs on the
/// commanded voltage, and each angle measurement corrects the rotor's angle
/// and velocity by fixed gains (an alpha-beta correction on the measured
/// state). The stator, the bristle state z and the friction force follow
/// from the corrected rotor through the model. With zero gains it is the
/// open-loop prediction.
///
/// Why this and not an extended Kalman filter on all five states: only the
/// angle is measured, the stator is stiff (5.7 kHz) and fully determined by
/// the known voltage, and z relaxes within a millisecond to what the
/// sliding velocity dictates. An EKF would spend a 5x5 Riccati update per
/// sample on states the measurement barely informs; correcting the rotor
/// and letting the model carry the rest costs one model step per sample.
/// Allocation-free.

#include "piezo/model/lugre_integrator.hpp"
#include "piezo/model/motor.hpp"
#include "piezo/model/parameters.hpp"

namespace piezo::model {

struct ObserverGains {
  double alpha = 0.3;  ///< fraction of the angle residual added to the angle
  double beta = 0.05;  ///< fraction added to the velocity, per measurement interval
  /// A measurement further than this from the prediction [rad] is an
  /// outlier: not used to correct (a spike, a misread word); the caller
  /// restarts the observer when they keep coming (the rotor is elsewhere).
  double gate_rad = 1e-3;
};

class LuGreObserver {
 public:
  /// @param ramp_time how long the signal chain takes to reach each new command [s] (> 0)
  LuGreObserver(const MotorParameters& p, const ObserverGains& gains, double ramp_time,
                double t0 = 0.0, const LuGreState& initial = {});

  /// A new command `V` [V] from time t on (samples in time order).
  void command(double t, double V);
  /// A measured angle at time t: advances to t, corrects, returns the
  /// residual (measured minus predicted, before the correction).
  double measure(double t, double theta);
  /// Advances to t without a measurement.
  void advance_to(double t);
  /// Starts again at t from state `y`, the input held at `V` [V] (no ramp):
  /// after a run of outliers, from where the rotor is measured to be.
  void restart(double t, const LuGreState& y, double V);

  [[nodiscard]] double time() const { return t_; }
  [[nodiscard]] const LuGreState& state() const { return integrator_.state(); }
  /// The friction force F_f [N] of the current state.
  [[nodiscard]] double friction() const { return motor_.friction(integrator_.state()).force; }

 private:
  MotorParameters p_;
  LuGreMotor motor_;
  ObserverGains gains_;
  double ramp_time_;
  LuGreIntegrator integrator_;
  double t_;
  // The input: a ramp from V_from_ (at t_command_) to V_to_ over ramp_time_, then V_to_.
  double t_command_ = 0.0, V_from_ = 0.0, V_to_ = 0.0;
  double t_last_measurement_ = -1.0;
};

}  // namespace piezo::model
