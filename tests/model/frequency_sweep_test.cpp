#include "piezo/model/frequency_sweep.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "piezo/model/sensitivity.hpp"

namespace piezo::model {
namespace {

TEST(SweepValues, LinearAndGeometric) {
  const auto lin = sweep_values(1.0, 5.0, 5, false);
  ASSERT_EQ(lin.size(), 5u);
  EXPECT_DOUBLE_EQ(lin[2], 3.0);
  const auto geo = sweep_values(1.0, 1000.0, 4, true);
  EXPECT_NEAR(geo[1], 10.0, 1e-9);
  EXPECT_NEAR(geo[3], 1000.0, 1e-9);
  EXPECT_THROW((void)sweep_values(0.0, 10.0, 3, true), std::invalid_argument);
}

// At the paper's baseline the per-period figures agree with the run's own
// angle: the mean velocity is the final angle over the time, and the
// steps add up to the angle gained after settling.
TEST(PeriodMetrics, AgreeWithTheRunAtTheBaseline) {
  const Parameters p;
  const PeriodSettings s{12, 2, 200};
  const StepMetrics m = period_metrics(p, FrictionModel::lugre, s);
  const double t_end = 12.0 / p.drive.f;
  const Sawtooth drive(p.drive.V0, p.drive.f, p.drive.D());
  EXPECT_NEAR(m.mean_velocity_rad_s,
              final_angle(p.motor, drive, FrictionModel::lugre, t_end) / t_end,
              1e-4 * m.mean_velocity_rad_s);
  EXPECT_GT(m.step_rad, 0.0);
  EXPECT_NEAR(m.step_rad * 10.0, m.mean_velocity_rad_s * t_end,
              0.25 * m.mean_velocity_rad_s * t_end)
      << "ten settled periods make most of the run's angle";
  EXPECT_GE(m.backslip_rad, 0.0);
}

// At 1 Hz both edges are slow enough for the rotor to stick: it follows the
// stator up and all the way back, so it makes no net step and slips back
// by the stator's full stroke over r: d_e * V0 / r.
TEST(PeriodMetrics, AtOneHertzTheRotorFollowsTheStatorBothWays) {
  const Parameters p = with_level(Parameters{}, "f", 1.0);
  const StepMetrics m = period_metrics(p, FrictionModel::lugre, {4, 1, 400});
  const double stroke = p.motor.d_e * p.drive.V0 / p.motor.r;
  EXPECT_LT(std::abs(m.step_rad), 1e-3 * stroke);
  EXPECT_NEAR(m.backslip_rad, stroke, 0.01 * stroke);
}

}  // namespace
}  // namespace piezo::model
