// The hybrid integrator's stick mode on its own: one RODAS4 step against the
// same interval in 256 steps (computed here), on a sticking state of a 10 Hz
// run with the drive ramping: the step converges as it shrinks, and the
// error estimate that the step control uses is the error's size.

#include "piezo/model/hybrid/stick_rosenbrock.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "piezo/model/simulate.hpp"
#include "piezo/model/step_control.hpp"
#include "piezo/model/waveform.hpp"

namespace piezo::model::hybrid {
namespace {

LuGreState fine(const StickRosenbrock& stick, LuGreState y, double V, double slope, double s,
                double h, int substeps) {
  const double dt = h / substeps;
  for (int i = 0; i < substeps; ++i) {
    LuGreState next{};
    (void)stick.step(y, V + slope * dt * i, slope, s, dt, next);
    y = next;
  }
  return y;
}

double scaled_distance(const LuGreState& a, const LuGreState& b, const LuGreState& scale) {
  double worst = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i)
    worst = std::max(worst, std::abs(a[i] - b[i]) / scale[i]);
  return worst;
}

/// A state of a 10 Hz run while the contact sticks (40 % into the 11th
/// period, as the benchmark takes it), with the drive there.
struct Sticking {
  LuGreState y;
  double V, slope, s;
};

Sticking sticking_state(const Parameters& p) {
  const Sawtooth drive(p.drive.V0, p.drive.f, p.drive.D());
  const double t = 10.4 / p.drive.f;
  const double times[] = {t};
  const Trajectory tr = simulate(p.motor, drive, FrictionModel::lugre, times);
  const LuGreState y{tr.x[0], tr.x_dot[0], tr.theta[0], tr.theta_dot[0], tr.z[0]};
  const double v = y[kXDot] - p.motor.r * y[kThetaDot];
  return {y, tr.V[0], drive.piece(t).slope, v >= 0.0 ? 1.0 : -1.0};
}

TEST(StickRosenbrock, OneStepConvergesAndItsEstimateTracksItsError) {
  const Parameters p;
  const LuGreState scale = state_scale<5>(p.motor);
  const StickRosenbrock stick(p.motor, scale, 1e-6);
  const Sticking at = sticking_state(p);
  const double omega_n = std::sqrt(p.motor.K / p.motor.M);
  double previous = 0.0, first = 0.0;
  for (double h = 256.0 / omega_n; h >= 2.0 / omega_n; h /= 2.0) {
    LuGreState one{};
    const double estimate = stick.step(at.y, at.V, at.slope, at.s, h, one);
    const double error =
        scaled_distance(one, fine(stick, at.y, at.V, at.slope, at.s, h, 256), scale);
    if (previous > 0.0) {
      EXPECT_LT(error, previous) << "h * omega_n = " << h * omega_n;
    }
    if (first == 0.0) first = error;
    // Over the stick mode's steps (16/omega_n and up) the step control's
    // estimate is the error's size (the method is stiff in this motor: the
    // error does not fall as a clean h^5).
    if (h >= 16.0 / omega_n) {
      EXPECT_LT(error, 5.0 * estimate) << "h * omega_n = " << h * omega_n;
    }
    previous = error;
  }
  EXPECT_LT(previous, 1e-5 * first);  // seven halvings
  EXPECT_LT(previous, 1e-11);         // of each state's scale
}

TEST(StickRosenbrock, TheErrorEstimateShrinksWithTheStep) {
  const Parameters p;
  const LuGreState scale = state_scale<5>(p.motor);
  const StickRosenbrock stick(p.motor, scale, 1e-6);
  const Sticking at = sticking_state(p);
  const double omega_n = std::sqrt(p.motor.K / p.motor.M);
  LuGreState out{};
  const double large = stick.step(at.y, at.V, at.slope, at.s, 16.0 / omega_n, out);
  const double small = stick.step(at.y, at.V, at.slope, at.s, 1.0 / omega_n, out);
  EXPECT_GT(large, 0.0);
  EXPECT_LT(small, large / 100.0);
}

}  // namespace
}  // namespace piezo::model::hybrid
