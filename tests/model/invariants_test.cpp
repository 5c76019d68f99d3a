// Physical sanity of simulated runs.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

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

TEST(Motors, SawtoothWithSlowRiseTurnsRotorForward) {
  const Parameters p;
  const Sawtooth drive(p.drive.V0, p.drive.f, p.drive.D());
  for (auto m : {FrictionModel::lugre, FrictionModel::coulomb}) {
    EXPECT_GT(final_angle(p.motor, drive, m, 1.0), 0.0) << to_string(m);
  }
}

TEST(Motors, MirroredSawtoothTurnsRotorBackward) {
  // A fast rise and slow fall (D < 0.5) drives the stick-slip motor in reverse.
  Parameters p;
  p.drive.C_dr = 0.25;
  p.drive.e_dr = 1.0;
  const Sawtooth drive(p.drive.V0, p.drive.f, p.drive.D());
  EXPECT_LT(final_angle(p.motor, drive, FrictionModel::lugre, 1.0), 0.0);
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

TEST(Simulate, DenseSamplesAgreeWithSingleEndSample) {
  const Parameters p;
  const Sawtooth drive(p.drive.V0, p.drive.f, p.drive.D());
  const auto dense = simulate(p.motor, drive, FrictionModel::lugre, uniform_times(0.5, 1e-4));
  const double end_only = final_angle(p.motor, drive, FrictionModel::lugre, 0.5);
  EXPECT_NEAR(dense.theta.back(), end_only, 1e-5 * std::abs(end_only));
}

}  // namespace
}  // namespace piezo::model
