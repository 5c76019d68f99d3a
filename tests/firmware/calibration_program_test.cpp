// The calibration's designed experiment on its own, against a rig of known
// kinematics (kinematic_plant.hpp): what it measures is what the plant is
// (its noise, its angle per volt in stick, its step per period each way),
// it ends at 0 V, and within its plan's stated duration.

#include "piezo/firmware/calibration_program.hpp"

#include <gtest/gtest.h>

#include "kinematic_plant.hpp"
#include "piezo/firmware/position_feed.hpp"

namespace piezo::firmware {
namespace {

TEST(CalibrationProgram, MeasuresThePlantsNoiseStrokeAndSteps) {
  CalibrationPlan plan;
  plan.frequencies = 1;  // 10 Hz: a slow enough rise sticks, an 80 V fall slips
  plan.D = 0.75;
  plan.r2_m = kR2;
  plan.flush_readings = 100;
  TestPlant plant;
  PositionFeed feed;
  CalibrationProgram program(plan, feed);
  double t = 0.0;
  const double limit = plan.duration_s(1e3);
  for (long tick = 0; t < limit && !program.finished(); ++tick, t += kDt) {
    if (tick % kTicksPerReading == 0) feed.publish(plant.read());
    plant.drive(program.next_voltage(t, kDt));
  }
  ASSERT_TRUE(program.finished()) << "within the plan's bound of " << limit << " s";
  EXPECT_EQ(plant.V, 0.0);
  const CalibrationResult& r = program.result();
  EXPECT_TRUE(r.complete);
  EXPECT_NEAR(r.noise_m, plant.noise_m, 0.3 * plant.noise_m);
  EXPECT_NEAR(r.rad_per_V, plant.stick_rad_per_V, 0.02 * plant.stick_rad_per_V);
  // At 80 V both edges of the fast side slip (3.2 kV/s) and the slow side
  // carries the rotor 80 V worth; at 40 V the fast side is too slow to slip
  // (1.6 kV/s) and the rotor swings back and forth without a step.
  const double full = plant.stick_rad_per_V * 80.0;
  const auto last = CalibrationPlan::kFractions - 1;
  EXPECT_NEAR(r.forward_rad[0][last], full, 0.03 * full);
  EXPECT_NEAR(r.reverse_rad[0][last], -full, 0.03 * full);
  EXPECT_NEAR(r.forward_rad[0][0], 0.0, 0.03 * full);
  EXPECT_NEAR(r.reverse_rad[0][0], 0.0, 0.03 * full);
}

}  // namespace
}  // namespace piezo::firmware
