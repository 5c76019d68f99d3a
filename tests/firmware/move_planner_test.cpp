// The move planner's step tables against the model they come from, and the
// alternative frequencies it offers within the drive's rate and slew limit.

#include "piezo/firmware/move_planner.hpp"

#include <gtest/gtest.h>

#include "piezo/model/simulate.hpp"
#include "piezo/model/waveform.hpp"

namespace piezo::firmware {
namespace {

TEST(MovePlanner, EachStepIsOnePeriodOfTheModelBothWays) {
  const model::Parameters p;  // Table 1
  MovePlanner planner(p.motor);
  const double D = p.drive.D();
  const StepTable& t = planner.steps(80.0, 10.0, D);
  const auto one_period = [&](double V, double rise) {
    return model::final_angle(p.motor, model::Sawtooth(V, 10.0, rise), model::FrictionModel::lugre,
                              0.1);
  };
  EXPECT_DOUBLE_EQ(t.forward_rad.back(), one_period(80.0, D));
  EXPECT_DOUBLE_EQ(t.reverse_rad.back(), -one_period(80.0, 1.0 - D));
  for (std::size_t i = 1; i < t.forward_rad.size(); ++i) {
    EXPECT_GT(t.forward_rad[i], t.forward_rad[i - 1]) << "a larger amplitude steps further";
    EXPECT_GT(t.reverse_rad[i], 0.0) << "magnitudes";
  }
  EXPECT_EQ(&planner.steps(80.0, 10.0, D), &t) << "kept per waveform, not computed again";
}

TEST(MovePlanner, AlternativesDoubleTheFrequencyWithinTheRateAndTheSlew) {
  const model::Parameters p;
  MovePlanner planner(p.motor);
  MoveSettings m;
  m.V0 = 80.0;
  m.f = 10.0;
  m.D = p.drive.D();
  planner.plan(m, true, 10'000.0, 20'000.0);
  EXPECT_DOUBLE_EQ(m.rad_per_V, p.motor.d_e / p.motor.r);
  ASSERT_EQ(m.alternative_count, 2);
  EXPECT_DOUBLE_EQ(m.alternatives[0].f, 20.0);
  EXPECT_DOUBLE_EQ(m.alternatives[1].f, 40.0);
  // A 400 Hz drive rate allows 20 Hz (20 updates a period), not 40.
  MoveSettings slow = m;
  slow.alternative_count = 0;
  planner.plan(slow, true, 400.0, 20'000.0);
  EXPECT_EQ(slow.alternative_count, 1);
  // A slew limit 40 Hz at 80 V would exceed (its fast edge: 80 V * 40 Hz / 0.25 = 12.8 kV/s).
  MoveSettings slewed = m;
  slewed.alternative_count = 0;
  planner.plan(slewed, true, 10'000.0, 10'000.0);
  EXPECT_EQ(slewed.alternative_count, 1);
}

}  // namespace
}  // namespace piezo::firmware
