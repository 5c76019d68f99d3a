// The integrators' default settings (closed form for Coulomb, DOPRI5 for
// LuGre), and DOPRI5 for both, against plain fixed-step RK4 solutions
// computed here, at the paper baseline, for both models at 10 and 20 Hz.
// The references are first shown to be converged themselves (halving the
// step changes them by far less than the tolerance being proven).

#include <gtest/gtest.h>

#include <cmath>
#include <tuple>

#include "../support/fixed_step_reference.hpp"
#include "piezo/model/simulate.hpp"

namespace piezo::model {
namespace {

constexpr double kRuntime = 4.8;
constexpr double kRequiredRelativeError = 1e-4;

using Case = std::tuple<FrictionModel, double>;

Parameters at_frequency(double f) {
  Parameters p;
  p.drive.f = f;
  return p;
}

class ConvergenceTest : public ::testing::TestWithParam<Case> {
 protected:
  FrictionModel friction = std::get<0>(GetParam());
  Parameters p = at_frequency(std::get<1>(GetParam()));
  Sawtooth drive{p.drive.V0, p.drive.f, p.drive.D()};

  [[nodiscard]] double reference_angle(double h) const {
    return friction == FrictionModel::lugre
               ? testing::lugre_rk4_angle(p.motor, drive, kRuntime, h)
               : testing::coulomb_rk4_angle(p.motor, drive, kRuntime, h);
  }
  [[nodiscard]] double adaptive_angle(IntegratorSettings settings = {}) const {
    return final_angle(p.motor, drive, friction, kRuntime, settings);
  }
};

TEST_P(ConvergenceTest, DefaultSettingsMatchFineFixedStepSolution) {
  const double fine = reference_angle(1e-6);
  const double coarse = reference_angle(2e-6);
  // Even at first order (switching limits Coulomb to it) the reference error
  // is then below a quarter of what is being proven.
  ASSERT_LT(std::abs(fine - coarse) / std::abs(fine), 0.25 * kRequiredRelativeError)
      << "the fixed-step reference itself is not converged";

  const double adaptive = adaptive_angle();
  EXPECT_LT(std::abs(adaptive - fine) / std::abs(fine), kRequiredRelativeError)
      << "adaptive " << adaptive << " rad, reference " << fine << " rad";
}

TEST_P(ConvergenceTest, Dopri5MatchesFineFixedStepSolution) {
  // The default for Coulomb is the closed form; DOPRI5 stays proven too.
  const double fine = reference_angle(1e-6);
  const double adaptive = adaptive_angle({.integrator = Integrator::dopri5});
  EXPECT_LT(std::abs(adaptive - fine) / std::abs(fine), kRequiredRelativeError)
      << "dopri5 " << adaptive << " rad, reference " << fine << " rad";
}

TEST_P(ConvergenceTest, TighterToleranceApproachesReference) {
  const double fine = reference_angle(1e-6);
  const double loose = adaptive_angle({.tolerance = 1e-6, .integrator = Integrator::dopri5});
  const double tight = adaptive_angle({.tolerance = 1e-9, .integrator = Integrator::dopri5});
  EXPECT_LT(std::abs(tight - fine), std::abs(loose - fine) + 1e-6 * std::abs(fine));
  EXPECT_LT(std::abs(tight - fine) / std::abs(fine), 1e-5);
}

INSTANTIATE_TEST_SUITE_P(PaperBaseline, ConvergenceTest,
                         ::testing::Combine(::testing::Values(FrictionModel::lugre,
                                                              FrictionModel::coulomb),
                                            ::testing::Values(10.0, 20.0)),
                         [](const auto& test_info) {
                           return std::string(to_string(std::get<0>(test_info.param))) + "_" +
                                  std::to_string(static_cast<int>(std::get<1>(test_info.param))) +
                                  "Hz";
                         });

}  // namespace
}  // namespace piezo::model
