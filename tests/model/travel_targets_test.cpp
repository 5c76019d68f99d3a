#include "piezo/model/travel_targets.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

namespace piezo::model {
namespace {

// The time lies between the ends of the two periods (the drive at 0 V)
// where the angle goes from short of the target to past it; the first
// period's end past it is one the model computes on its own.
TEST(TravelTime, LiesBetweenThePeriodEndsWhereTheAngleCrossesTheTarget) {
  Parameters p;
  const double t = travel_time(p, 0.010, FrictionModel::lugre, 3.0);
  ASSERT_TRUE(std::isfinite(t));
  const Sawtooth drive(p.drive.V0, p.drive.f, p.drive.rise());
  const double period = 1.0 / p.drive.f;
  const double before = std::floor(t / period) * period;
  EXPECT_LT(final_angle(p.motor, drive, FrictionModel::lugre, before), 0.010);
  EXPECT_GE(final_angle(p.motor, drive, FrictionModel::lugre, before + period), 0.010);
  EXPECT_TRUE(std::isnan(travel_time(p, 0.010, FrictionModel::lugre, 0.5 * t)));
  // Backwards: the mirrored sawtooth covers a negative angle.
  p.drive.direction = Direction::reverse;
  EXPECT_TRUE(std::isfinite(travel_time(p, -0.010, FrictionModel::lugre, 3.0)));
}

// Targets computed from known parameters give those parameters back from
// another start: the fit finds what made the figures, per target settings.
TEST(TravelTargets, RecoverTheParametersThatMadeThem) {
  Parameters truth;
  truth.motor.F_N = 12e-3;
  truth.motor.sigma0 = 4000.0;
  std::vector<TravelTarget> targets{{{{"f", 10.0}}, 0.010, 0.0},
                                    {{{"f", 20.0}, {"d_e", 0.4e-6}}, 0.010, 0.0},
                                    {{{"f", 15.0}, {"V0", 70.0}}, 0.008, 0.0}};
  for (auto& t : targets) {
    t.time_s = travel_time(with_settings(truth, t), t.angle_rad, FrictionModel::lugre, 10.0);
    ASSERT_TRUE(std::isfinite(t.time_s));
  }
  FitSettings settings;
  settings.free = {"F_N", "sigma0"};
  const TargetFitResult r = fit_travel_targets(Parameters{}, targets, settings);
  EXPECT_TRUE(r.fit.converged) << r.fit.stop_reason << " after " << r.fit.iterations;
  EXPECT_NEAR(r.fit.parameters.motor.F_N, truth.motor.F_N, 0.01 * truth.motor.F_N);
  EXPECT_NEAR(r.fit.parameters.motor.sigma0, truth.motor.sigma0, 0.03 * truth.motor.sigma0);
  ASSERT_EQ(r.targets.size(), targets.size());
  for (const auto& o : r.targets) EXPECT_LT(std::abs(o.relative_error), 0.005);
  // Three targets, two free: intervals are defined and hold the truth.
  EXPECT_LE(r.fit.fitted[0].low95, truth.motor.F_N * 1.01);
  EXPECT_GE(r.fit.fitted[0].high95, truth.motor.F_N * 0.99);
  // The start missed them.
  EXPECT_GT(std::abs(r.initial_targets[0].relative_error), 0.2);
}

// A parameter free for one target alone ("d_e@2") takes that target's own
// value: d_e identified per frequency, as the paper does, comes back.
TEST(TravelTargets, AParameterOfOneTargetIsFittedForItAlone) {
  std::vector<TravelTarget> targets{{{{"f", 10.0}, {"d_e", 0.42e-6}}, 0.010, 0.0},
                                    {{{"f", 20.0}, {"d_e", 0.26e-6}}, 0.010, 0.0}};
  for (auto& t : targets) {
    t.time_s = travel_time(with_settings(Parameters{}, t), t.angle_rad, FrictionModel::lugre, 10.0);
    t.settings.pop_back();  // the fit is not told d_e
  }
  FitSettings settings;
  settings.free = {"d_e@1", "d_e@2"};
  const TargetFitResult r = fit_travel_targets(Parameters{}, targets, settings);
  ASSERT_EQ(r.fit.fitted.size(), 2u);
  EXPECT_EQ(r.fit.fitted[0].name, "d_e@1");
  EXPECT_NEAR(r.fit.fitted[0].value, 0.42e-6, 0.005 * 0.42e-6);
  EXPECT_NEAR(r.fit.fitted[1].value, 0.26e-6, 0.005 * 0.26e-6);
  EXPECT_EQ(r.fit.parameters.motor.d_e, Parameters{}.motor.d_e);  // no shared d_e was fitted
  // A target's own free parameter it also sets, or a number that is no target's, is refused.
  settings.free = {"d_e@3"};
  EXPECT_THROW((void)fit_travel_targets(Parameters{}, targets, settings), std::invalid_argument);
  targets[0].settings.emplace_back("d_e", 0.4e-6);
  settings.free = {"d_e@1"};
  EXPECT_THROW((void)fit_travel_targets(Parameters{}, targets, settings), std::invalid_argument);
}

TEST(TravelTargets, RefuseMoreFreeParametersThanTargetsAndBadTargets) {
  FitSettings settings;
  settings.free = {"F_N", "sigma0"};
  const std::vector<TravelTarget> one{{{{"f", 10.0}}, 0.010, 4.9}};
  EXPECT_THROW((void)fit_travel_targets(Parameters{}, one, settings), std::invalid_argument);
  settings.free = {"F_N"};
  EXPECT_THROW((void)fit_travel_targets(Parameters{}, {{{{"f", 10.0}}, 0.010, 0.0}}, settings),
               std::invalid_argument);
  EXPECT_THROW((void)fit_travel_targets(Parameters{}, {{{{"nope", 1.0}}, 0.010, 4.9}}, settings),
               std::invalid_argument);
  EXPECT_THROW((void)fit_travel_targets(Parameters{}, {{{{"f", -1.0}}, 0.010, 4.9}}, settings),
               std::invalid_argument);
}

}  // namespace
}  // namespace piezo::model
