// The simulated plant across an idle gap: once the motor is at rest under a
// held output, the gap costs nothing and changes nothing. Integrated at the
// stator's step, a day of idle would take the drive thread hours on the
// next write (30 s once took 1.8 s); here it is skipped, and the state is
// the one a short gap gives.

#include <gtest/gtest.h>

#include "piezo/hal/sim/plant.hpp"

namespace piezo::hal::sim {
namespace {

constexpr TimeNs kMs = 1'000'000;
constexpr TimeNs kDay = 86'400'000'000'000;

/// A plant kicked by a few sawtooth-like steps of its input, then disabled
/// at 20 ms; `gap` later, a new input.
PlantSnapshot after_idle(TimeNs gap) {
  Plant plant(model::MotorParameters{}, AmplifierSettings{}, 0);
  plant.set_enabled(0, true);
  for (int k = 0; k < 10; ++k) {
    plant.set_input(k * kMs, 0.4 * k);  // a slow rise (20 V/ms at the amplifier)
  }
  plant.set_input(10 * kMs, 0.0);  // and a fast fall: the rotor slips
  plant.set_enabled(20 * kMs, false);
  plant.set_input(20 * kMs + gap, 0.0);
  return plant.latest();
}

TEST(PlantIdle, ADayOfIdleIsSkippedAndChangesNothing) {
  const PlantSnapshot short_gap = after_idle(500 * kMs);
  const PlantSnapshot day = after_idle(kDay);
  EXPECT_EQ(day.t, 20 * kMs + kDay);
  EXPECT_NE(short_gap.theta, 0.0) << "the kick moved the rotor";
  EXPECT_NEAR(day.theta, short_gap.theta, 1e-12);
  EXPECT_NEAR(day.theta_dot, 0.0, 1e-9);
  EXPECT_EQ(day.V_out, 0.0);
}

}  // namespace
}  // namespace piezo::hal::sim
