// The LuGre model by Taylor series (the hybrid integrator's series mode)
// against a tight DOPRI5 computed here, at 5, 10, 20 and 50 Hz, forward and
// reverse, at the paper baseline and at the section 5 extremes: the angle
// at the end and every 0.1 ms sample within 1e-4 of the reference's range
// (relative, with an absolute floor of 1e-4 of a step's stroke for tiny
// motions). The reference is first shown to be converged itself.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <tuple>

#include "piezo/model/simulate.hpp"

namespace piezo::model {
namespace {

constexpr double kRuntime = 1.0;
constexpr double kRequired = 1e-4;

Trajectory run(const Parameters& p, const Excitation& drive, Integrator integrator,
               double tolerance) {
  const auto times = uniform_times(kRuntime, 1e-4);
  return simulate(p.motor, drive, FrictionModel::lugre, times,
                  {.tolerance = tolerance, .integrator = integrator});
}

/// The largest sample difference over the reference's range of angles.
double sampled_error(const Trajectory& a, const Trajectory& ref, double floor) {
  double diff = 0.0, lo = ref.theta.front(), hi = lo;
  for (std::size_t i = 0; i < ref.size(); ++i) {
    diff = std::max(diff, std::abs(a.theta[i] - ref.theta[i]));
    lo = std::min(lo, ref.theta[i]);
    hi = std::max(hi, ref.theta[i]);
  }
  return diff / std::max(hi - lo, floor);
}

using Case = std::tuple<double, Direction>;

class LuGreTaylor : public ::testing::TestWithParam<Case> {};

TEST_P(LuGreTaylor, MatchesATightDopri5) {
  Parameters p;
  p.drive.f = std::get<0>(GetParam());
  p.drive.direction = std::get<1>(GetParam());
  const Sawtooth drive(p.drive.V0, p.drive.f, p.drive.rise());
  const double floor = 1e-4 * p.motor.d_e * p.drive.V0 / p.motor.r;
  const Trajectory ref = run(p, drive, Integrator::dopri5, 1e-10);
  const Trajectory check = run(p, drive, Integrator::dopri5, 1e-9);
  ASSERT_LT(sampled_error(check, ref, floor), 0.25 * kRequired) << "the reference is not converged";
  const Trajectory series = run(p, drive, Integrator::taylor, 1e-6);
  EXPECT_EQ(series.stats.integrator, Integrator::taylor);
  EXPECT_LT(sampled_error(series, ref, floor), kRequired);
  const double end = ref.theta.back();
  EXPECT_LT(std::abs(series.theta.back() - end) / std::max(std::abs(end), floor), kRequired)
      << series.theta.back() << " against " << end;
  std::cout << p.drive.f << " Hz " << name(p.drive.direction) << ": theta(end) "
            << series.theta.back() << " (reference " << end << "), " << series.stats.steps
            << " steps, " << series.stats.mode_switches << " reversals; DOPRI5 at 1e-6 takes "
            << run(p, drive, Integrator::dopri5, 1e-6).stats.steps << "\n";
}

INSTANTIATE_TEST_SUITE_P(Frequencies, LuGreTaylor,
                         ::testing::Combine(::testing::Values(5.0, 10.0, 20.0, 50.0),
                                            ::testing::Values(Direction::forward,
                                                              Direction::reverse)));

// The section 5 extremes (each parameter at the end of its studied range)
// hold the same bound at 10 Hz.
TEST(LuGreTaylorExtremes, MatchATightDopri5) {
  struct Change {
    const char* name;
    double factor;
  };
  for (const Change& c :
       {Change{"sigma0", 0.5}, Change{"sigma0", 2.0}, Change{"sigma1", 0.5}, Change{"sigma1", 2.0},
        Change{"F_N", 0.5}, Change{"F_N", 2.0}, Change{"d_e", 0.5}, Change{"d_e", 1.5}}) {
    SCOPED_TRACE(std::string(c.name) + " x" + std::to_string(c.factor));
    Parameters p;
    double& value = find_parameter(c.name)->ref(p);
    value *= c.factor;
    const Sawtooth drive(p.drive.V0, p.drive.f, p.drive.rise());
    const double floor = 1e-4 * p.motor.d_e * p.drive.V0 / p.motor.r;
    const Trajectory ref = run(p, drive, Integrator::dopri5, 1e-10);
    const Trajectory series = run(p, drive, Integrator::taylor, 1e-6);
    EXPECT_LT(sampled_error(series, ref, floor), kRequired);
  }
}

TEST(LuGreTaylorChoice, CoulombIsRefused) {
  Parameters p;
  const Sawtooth drive(p.drive.V0, p.drive.f, p.drive.rise());
  const double times[] = {0.1};
  EXPECT_THROW((void)simulate(p.motor, drive, FrictionModel::coulomb, times,
                              {.integrator = Integrator::taylor}),
               std::invalid_argument);
}

}  // namespace
}  // namespace piezo::model
