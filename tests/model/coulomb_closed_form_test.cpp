// The Coulomb model's closed-form integrator: against fixed-step RK4
// computed here at the extreme levels of the sweeps (paper section 5's
// one-at-a-time levels, and the frequency sweep's ends), its switches on
// their events, and its refusals.

#include "piezo/model/coulomb_closed_form.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <ostream>
#include <string>
#include <vector>

#include "../support/fixed_step_reference.hpp"
#include "piezo/model/simulate.hpp"

namespace piezo::model {
namespace {

constexpr double kRequiredRelativeError = 1e-4;

struct SweepCase {
  std::string name;
  Parameters p;
  double runtime;  ///< [s]
  double h;        ///< RK4 reference step [s]; the check doubles it
};

void PrintTo(const SweepCase& c, std::ostream* os) {
  *os << c.name;
}

Parameters with(void (*change)(Parameters&)) {
  Parameters p;
  change(p);
  return p;
}

std::vector<SweepCase> sweep_extremes() {
  return {
      {"V0_72", with([](Parameters& p) { p.drive.V0 = 72.0; }), 4.8, 1e-6},
      {"V0_88", with([](Parameters& p) { p.drive.V0 = 88.0; }), 4.8, 1e-6},
      {"f_8", with([](Parameters& p) { p.drive.f = 8.0; }), 4.8, 1e-6},
      {"f_12", with([](Parameters& p) { p.drive.f = 12.0; }), 4.8, 1e-6},
      {"mu_0_09", with([](Parameters& p) { p.motor.mu = 0.09; }), 4.8, 1e-6},
      {"mu_0_11", with([](Parameters& p) { p.motor.mu = 0.11; }), 4.8, 1e-6},
      {"D_0_675", with([](Parameters& p) { p.drive.e_dr = 0.675 / p.drive.C_dr; }), 4.8, 1e-6},
      {"D_0_825", with([](Parameters& p) { p.drive.e_dr = 0.825 / p.drive.C_dr; }), 4.8, 1e-6},
      // The frequency sweep's ends: 2 periods at 1 Hz, 40 near the stator at 2 kHz.
      {"f_1", with([](Parameters& p) { p.drive.f = 1.0; }), 2.0, 2.5e-7},
      {"f_2000", with([](Parameters& p) { p.drive.f = 2000.0; }), 0.02, 1.25e-7},
  };
}

class ClosedFormAtSweepExtremes : public ::testing::TestWithParam<SweepCase> {};

TEST_P(ClosedFormAtSweepExtremes, MatchesFineFixedStepRk4) {
  const auto& c = GetParam();
  const Sawtooth drive(c.p.drive.V0, c.p.drive.f, c.p.drive.D());
  const double fine = testing::coulomb_rk4_angle(c.p.motor, drive, c.runtime, c.h);
  const double coarse = testing::coulomb_rk4_angle(c.p.motor, drive, c.runtime, 2.0 * c.h);
  ASSERT_LT(std::abs(fine - coarse) / std::abs(fine), 0.25 * kRequiredRelativeError)
      << "the fixed-step reference itself is not converged";
  const double exact = final_angle(c.p.motor, drive, FrictionModel::coulomb, c.runtime,
                                   {.integrator = Integrator::closed_form});
  EXPECT_LT(std::abs(exact - fine) / std::abs(fine), kRequiredRelativeError)
      << "closed form " << exact << " rad, RK4 " << fine << " rad";
}

INSTANTIATE_TEST_SUITE_P(Sweeps, ClosedFormAtSweepExtremes, ::testing::ValuesIn(sweep_extremes()),
                         [](const auto& param_info) { return param_info.param.name; });

class ClosedFormSwitches : public ::testing::Test {
 protected:
  Parameters p = [] {
    Parameters q;
    q.drive.f = 20.0;  // many switches: the 20 Hz fall rings the stator into stick and slip
    return q;
  }();
  Sawtooth drive{p.drive.V0, p.drive.f, p.drive.D()};
  std::vector<double> times = uniform_times(0.5, 1e-3);
};

TEST_F(ClosedFormSwitches, LandOnTheEventsDopri5Locates) {
  // Some switches graze: the holding force touches F_c at a shallow angle,
  // so their time is ill-conditioned; DOPRI5 needs 1e-12 to place them
  // within 1e-8 s (at 1e-10 it is 1.4e-8 s off and then switches twice
  // fewer over these 0.5 s).
  const auto exact = simulate(p.motor, drive, FrictionModel::coulomb, times,
                              {.integrator = Integrator::closed_form});
  const auto located = simulate(p.motor, drive, FrictionModel::coulomb, times,
                                {.tolerance = 1e-12, .integrator = Integrator::dopri5});
  ASSERT_GT(exact.switch_times.size(), 100U);
  for (std::size_t i = 0; i < std::min(exact.switch_times.size(), located.switch_times.size());
       ++i) {
    if (std::abs(exact.switch_times[i] - located.switch_times[i]) > 1e-8) {
      ADD_FAILURE() << "first difference at switch " << i << ": " << exact.switch_times[i]
                    << " s (closed form) against " << located.switch_times[i] << " s";
      break;
    }
  }
  ASSERT_EQ(exact.switch_times.size(), located.switch_times.size());
  for (std::size_t i = 0; i < exact.switch_times.size(); ++i) {
    ASSERT_NEAR(exact.switch_times[i], located.switch_times[i], 1e-8) << "switch " << i;
  }
}

TEST_F(ClosedFormSwitches, EachSwitchIsWhereItsConditionHolds) {
  const auto run = simulate(p.motor, drive, FrictionModel::coulomb, times,
                            {.integrator = Integrator::closed_form});
  // Sampled exactly at the switches: the state there ends the mode before it.
  const auto at = simulate(p.motor, drive, FrictionModel::coulomb, run.switch_times,
                           {.integrator = Integrator::closed_form});
  const double speed_scale = p.motor.d_e * p.drive.V0 * p.drive.f;  // stator's mean speed
  ASSERT_EQ(at.size(), run.switch_times.size());
  for (std::size_t i = 0; i < at.size(); ++i) {
    // A slip ends where the sliding velocity is back at zero (its friction
    // is F_c all along); a stick ends where the force holding rotor and
    // stator together reaches F_c (its sliding velocity is zero all along).
    const double v = at.x_dot[i] - p.motor.r * at.theta_dot[i];
    EXPECT_LT(std::abs(v), 1e-9 * speed_scale) << "switch " << i << " at " << at.t[i] << " s";
    // The sample time is an absolute double (1 ulp = 56 as near 0.5 s), and
    // just after a corner the holding force moves at up to 5e4 N/s.
    EXPECT_NEAR(std::abs(at.F_f[i]), p.motor.F_c(), 1e-8 * p.motor.F_c())
        << "switch " << i << " at " << at.t[i] << " s";
  }
}

TEST(ClosedForm, LuGreIsRefusedByName) {
  const Parameters p;
  const Sawtooth drive(p.drive.V0, p.drive.f, p.drive.D());
  try {
    (void)final_angle(p.motor, drive, FrictionModel::lugre, 0.1,
                      {.integrator = Integrator::closed_form});
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("Coulomb model only"), std::string::npos) << e.what();
  }
}

TEST(ClosedForm, AStatorThatDoesNotRingFallsBackToDopri5) {
  Parameters p;
  p.motor.C = 3.0 * std::sqrt(p.motor.K * p.motor.M);  // overdamped
  ASSERT_FALSE(coulomb_closed_form_applies(p.motor));
  const Sawtooth drive(p.drive.V0, p.drive.f, p.drive.D());
  EXPECT_EQ(
      final_angle(p.motor, drive, FrictionModel::coulomb, 0.2),
      final_angle(p.motor, drive, FrictionModel::coulomb, 0.2, {.integrator = Integrator::dopri5}));
  EXPECT_THROW((void)final_angle(p.motor, drive, FrictionModel::coulomb, 0.2,
                                 {.integrator = Integrator::closed_form}),
               std::invalid_argument);
}

}  // namespace
}  // namespace piezo::model
