// Physical sanity of simulated runs.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "piezo/model/simulate.hpp"

namespace piezo::model {
namespace {

TEST(LuGre, BristleDeflectionStaysWithinSteadyStateBound) {
  // Started inside |z| <= F_c/sigma0, the LuGre bristle never leaves it, up
  // to the error of the integrator's dense output sampled between its steps
  // while z sits at the bound: up to 1e-4 of the bound measured on x86-64,
  // 1.2e-4 on arm64 (a different libm); 2e-4 allowed.
  const Parameters p;
  const Sawtooth drive(p.drive.V0, p.drive.f, p.drive.D());
  const auto tr = simulate(p.motor, drive, FrictionModel::lugre, uniform_times(1.0, 1e-5));
  const double bound = p.motor.F_c() / p.motor.sigma0;
  for (double z : tr.z) ASSERT_LE(std::abs(z), bound * (1 + 2e-4));
}

TEST(Motors, NoDriveNoMotion) {
  Parameters p;
  p.drive.V0 = 0.0;
  const Sawtooth drive(p.drive.V0, p.drive.f, p.drive.D());
  for (auto m : {FrictionModel::lugre, FrictionModel::coulomb}) {
    EXPECT_EQ(final_angle(p.motor, drive, m, 0.5), 0.0) << to_string(m);
  }
}

// The mirrored sawtooth (fast rise, slow fall) turns the rotor backwards,
// about as fast: the stator's stroke and the friction are the same both ways.
// Over the paper's 4.8 s, so that the first period (a slip edge first in
// reverse) weighs little.
TEST(Motors, MirroredSawtoothTurnsRotorBackwardAboutAsFast) {
  const Parameters p;
  const Sawtooth forward(p.drive.V0, p.drive.f, rise_fraction(p.drive.D(), Direction::forward));
  const Sawtooth reverse(p.drive.V0, p.drive.f, rise_fraction(p.drive.D(), Direction::reverse));
  for (auto m : {FrictionModel::lugre, FrictionModel::coulomb}) {
    const double ahead = final_angle(p.motor, forward, m, 4.8);
    const double back = final_angle(p.motor, reverse, m, 4.8);
    EXPECT_LT(back, 0.0) << to_string(m);
    EXPECT_NEAR(-back, ahead, 0.05 * ahead) << to_string(m);
  }
}

TEST(Motors, SawtoothWithSlowRiseTurnsRotorForward) {
  const Parameters p;
  const Sawtooth drive(p.drive.V0, p.drive.f, p.drive.D());
  for (auto m : {FrictionModel::lugre, FrictionModel::coulomb}) {
    EXPECT_GT(final_angle(p.motor, drive, m, 1.0), 0.0) << to_string(m);
  }
}

TEST(Simulate, SamplesExactlyAtRequestedTimes) {
  const Parameters p;
  const Sawtooth drive(p.drive.V0, p.drive.f, p.drive.D());
  const auto times = uniform_times(0.3, 0.07);
  const auto tr = simulate(p.motor, drive, FrictionModel::lugre, times);
  ASSERT_EQ(tr.size(), times.size());
  EXPECT_DOUBLE_EQ(tr.t.back(), 0.3);
  for (std::size_t i = 0; i < times.size(); ++i) {
    EXPECT_DOUBLE_EQ(tr.t[i], times[i]);
    EXPECT_NEAR(tr.V[i], drive.voltage(times[i]), 1e-12);
  }
}

TEST(Simulate, EveryColumnOfDenseSamplesIsTheMotorsState) {
  // The hybrid's samples at 10 kHz (most of them interpolated inside its
  // linear and stick steps, a step's worth at a time) against a tight
  // DOPRI5, column by column: the rotor's and the bristle's to 1e-3 of
  // their range; the stator's position to 1e-2 (its ringing is settled at
  // stick entry, docs/model.md; its velocity, whose ringing that is, is
  // checked through F_f). V is the drive at the sample's time and F_f the
  // friction of the sample's own state.
  const Parameters p;
  const Sawtooth drive(p.drive.V0, p.drive.f, p.drive.D());
  const auto times = uniform_times(0.3, 1e-4);
  const auto hybrid = simulate(p.motor, drive, FrictionModel::lugre, times);
  const auto tight = simulate(p.motor, drive, FrictionModel::lugre, times,
                              {.tolerance = 1e-10, .integrator = Integrator::dopri5});
  const std::pair<std::vector<double> Trajectory::*, double> columns[] = {
      {&Trajectory::theta, 1e-3},
      {&Trajectory::theta_dot, 1e-3},
      {&Trajectory::z, 1e-3},
      {&Trajectory::F_f, 1e-3},
      {&Trajectory::x, 1e-2}};
  for (const auto& [column, share] : columns) {
    const auto& reference = tight.*column;
    const auto [lo, hi] = std::minmax_element(reference.begin(), reference.end());
    for (std::size_t i = 0; i < times.size(); ++i) {
      ASSERT_NEAR((hybrid.*column)[i], reference[i], share * (*hi - *lo)) << "sample " << i;
    }
  }
  const LuGreMotor motor(p.motor);
  for (std::size_t i = 0; i < times.size(); ++i) {
    EXPECT_NEAR(hybrid.V[i], drive.voltage(times[i]), 1e-12);
    const LuGreState y{hybrid.x[i], hybrid.x_dot[i], hybrid.theta[i], hybrid.theta_dot[i],
                       hybrid.z[i]};
    // To rounding of the friction's own terms (each about F_c; a target
    // that fuses multiply-adds may round the sum differently).
    EXPECT_NEAR(hybrid.F_f[i], motor.friction(y).force, 1e-12 * p.motor.F_c()) << "sample " << i;
  }
}

TEST(Simulate, DenseSamplesAgreeWithSingleEndSample) {
  const Parameters p;
  const Sawtooth drive(p.drive.V0, p.drive.f, p.drive.D());
  const auto dense = simulate(p.motor, drive, FrictionModel::lugre, uniform_times(0.5, 1e-4));
  const double end_only = final_angle(p.motor, drive, FrictionModel::lugre, 0.5);
  EXPECT_NEAR(dense.theta.back(), end_only, 1e-5 * std::abs(end_only));
}

TEST(Simulate, RecordsTheColumnsAskedForIntoTheStorageGiven) {
  const Parameters p;
  const Sawtooth drive(p.drive.V0, p.drive.f, p.drive.D());
  const auto times = uniform_times(0.3, 1e-4);
  ColumnSet theta_only;
  theta_only.set(0).set(4);
  for (const auto integrator : {Integrator::hybrid, Integrator::dopri5}) {
    const Trajectory whole =
        simulate(p.motor, drive, FrictionModel::lugre, times, {.integrator = integrator});
    Trajectory used = whole;  // a used trajectory: its samples are dropped, its memory written
    const double* memory = used.theta.data();
    const Trajectory some =
        simulate(p.motor, drive, FrictionModel::lugre, times,
                 {.integrator = integrator, .columns = theta_only}, std::move(used));
    EXPECT_EQ(some.t, whole.t);
    EXPECT_EQ(some.theta, whole.theta);
    EXPECT_EQ(some.theta.data(), memory) << "the storage given is the one written";
    EXPECT_TRUE(some.V.empty() && some.x.empty() && some.z.empty() && some.F_f.empty());
    EXPECT_EQ(some.stats.steps, whole.stats.steps);
  }
}

}  // namespace
}  // namespace piezo::model
