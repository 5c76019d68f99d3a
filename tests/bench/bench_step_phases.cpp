// Where DOPRI5 spends its steps on LuGre: accepted steps per 5 % of the
// drive period, averaged over 4.8 s, with the step cap the simulator uses
// (2/omega_n) or none. The first bins after each corner (phase 0 and D)
// are the stator's ringing; the rest is held by the stability limit.
// Beside the steps, how often the sliding velocity v = x' - r theta'
// changes sign between accepted steps: while the stator rings, the friction
// (and the bristle) turn with it, which is why those steps cannot grow.
// Usage: bench_step_phases [f_hz] [tolerance] [cap_s]   (cap 0: the default)

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <cstdlib>

#include "piezo/model/dopri5.hpp"
#include "piezo/model/motor.hpp"
#include "piezo/model/parameters.hpp"
#include "piezo/model/step_control.hpp"
#include "piezo/model/waveform.hpp"

using namespace piezo::model;

int main(int argc, char** argv) {
  Parameters p;
  p.drive.f = argc > 1 ? std::atof(argv[1]) : 10.0;
  const double tolerance = argc > 2 ? std::atof(argv[2]) : 1e-6;
  const double cap =
      argc > 3 && std::atof(argv[3]) > 0 ? std::atof(argv[3]) : max_stable_step(p.motor);
  constexpr double kRuntime = 4.8;
  constexpr int kBins = 20;
  const Sawtooth drive(p.drive.V0, p.drive.f, p.drive.D());
  const LuGreMotor motor(p.motor);
  LuGreState atol = state_scale<5>(p.motor);
  for (double& a : atol) a *= tolerance;
  Dopri5<5> stepper(tolerance, atol, cap);
  LinearPiece voltage{0.0, 0.0, 0.0};
  auto rhs = [&](const LuGreState& y, LuGreState& dy, double t) {
    motor.derivative(voltage.at(t), y, dy);
  };
  std::array<long, kBins> steps{}, reversals{};
  const auto sliding = [&](const LuGreState& s) { return s[1] - p.motor.r * s[3]; };
  const double period = 1.0 / p.drive.f;
  LuGreState y{};
  double t = 0.0, h = 1e-7;
  while (t < kRuntime) {
    const double segment_end = std::min(drive.next_breakpoint(t), kRuntime);
    voltage = drive.piece(t);
    stepper.initialize(rhs, t, y, std::min(h, segment_end - t));
    while (segment_end - stepper.time() > 1e-13) {
      const double v_before = sliding(stepper.state());
      stepper.step(rhs, segment_end - stepper.time());
      const double phase = std::fmod(stepper.time(), period) / period;
      const auto bin =
          static_cast<std::size_t>(std::min(kBins - 1, static_cast<int>(phase * kBins)));
      ++steps[bin];
      if (v_before * sliding(stepper.state()) < 0.0) ++reversals[bin];
    }
    y = stepper.state();
    t = segment_end;
    h = stepper.proposed_step();
  }
  const double periods = kRuntime / period;
  fmt::print("LuGre {} Hz, tolerance {:g}, step cap {:.1f} us: {} steps, D = {:.3f}\n", p.drive.f,
             tolerance, 1e6 * cap, stepper.steps(), p.drive.D());
  fmt::print("{:>11} {:>16} {:>14} {:>18}\n", "phase", "steps/period", "mean step/us",
             "v reversals/period");
  for (std::size_t i = 0; i < kBins; ++i) {
    const double per_period = static_cast<double>(steps[i]) / periods;
    fmt::print("{:5.2f}-{:4.2f} {:>16.0f} {:>14.1f} {:>18.1f}\n", static_cast<double>(i) / kBins,
               static_cast<double>(i + 1) / kBins, per_period, 1e6 * period / kBins / per_period,
               static_cast<double>(reversals[i]) / periods);
  }
  return 0;
}
