// The hybrid integrator's series mode, part by part: the evaluations
// against a plain Horner, the recurrence against the motor's own equations
// (the series must satisfy them order by order), the step bound against
// its definition, the zero of v against a bisection of the polynomial, and
// the step bound's root against std::pow.

#include "piezo/model/hybrid/series.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "piezo/model/hybrid/nth_root.hpp"
#include "piezo/model/parameters.hpp"
#include "piezo/model/step_control.hpp"

namespace piezo::model::hybrid {
namespace {

double horner(const Coefficients& c, double tau) {
  double sum = 0.0;
  for (int k = kOrder; k >= 0; --k) sum = sum * tau + c[static_cast<std::size_t>(k)];
  return sum;
}

double horner_slope(const Coefficients& c, double tau) {
  double sum = 0.0;
  for (int k = kOrder; k >= 1; --k) sum = sum * tau + k * c[static_cast<std::size_t>(k)];
  return sum;
}

Coefficients random_coefficients(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Coefficients c{};
  for (double& x : c) x = u(rng);
  return c;
}

TEST(SeriesEvaluation, AtAndSlopeAtAreThePolynomialAndItsDerivative) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> tau(-1.5, 1.5);
  for (int i = 0; i < 1000; ++i) {
    const Coefficients c = random_coefficients(rng);
    const double t = tau(rng);
    double scale = 0.0, slope_scale = 0.0;  // the sums of |terms|: rounding's size
    for (int k = 0; k <= kOrder; ++k) {
      scale += std::abs(c[static_cast<std::size_t>(k)]) * std::pow(std::abs(t), k);
      if (k > 0)
        slope_scale += k * std::abs(c[static_cast<std::size_t>(k)]) * std::pow(std::abs(t), k - 1);
    }
    EXPECT_NEAR(at(c, t), horner(c, t), 1e-14 * scale) << t;
    EXPECT_NEAR(slope_at(c, t), horner_slope(c, t), 1e-14 * slope_scale) << t;
  }
  const Coefficients c = random_coefficients(rng);
  EXPECT_EQ(at(c, 0.0), c[0]);
  EXPECT_EQ(slope_at(c, 0.0), c[1]);
}

/// The state's derivative by the motor's equations with the sliding sign
/// s held (z' = v - s kappa v z, or 0 on a saturated bristle).
LuGreState derivative(const MotorParameters& p, const LuGreState& y, double V, double s,
                      bool saturated) {
  const double v = y[kXDot] - p.r * y[kThetaDot];
  const double kappa = p.sigma0 / p.F_c();
  const double zd = saturated ? 0.0 : v - s * kappa * v * y[kZ];
  const double F = p.sigma0 * y[kZ] + p.sigma1 * zd + p.sigma2 * v;
  return {y[kXDot], (p.K * p.d_e * V - p.C * y[kXDot] - p.K * y[kX] - F) / p.M, y[kThetaDot],
          p.r * F / p.J, zd};
}

TEST(SeriesMotor, TheSeriesSatisfiesTheMotorsEquations) {
  const Parameters p;
  const SeriesMotor motor(p.motor);
  const double omega_n = std::sqrt(p.motor.K / p.motor.M);
  const double kappa = p.motor.sigma0 / p.motor.F_c();
  for (const bool saturated : {false, true}) {
    for (const double s : {1.0, -1.0}) {
      // A sliding state: the stator moving, the bristle part-way.
      const LuGreState y0{2e-7, s * 3e-3, 0.01, s * 1e-3, saturated ? s / kappa : 0.3 * s / kappa};
      const double V0 = 40.0, slope = 800.0;
      Expansion e{};
      motor.expand(y0, V0, slope, s, saturated, e);
      for (std::size_t i = 0; i < 5; ++i) EXPECT_EQ(e.y[i][0], y0[i]);
      // y'(tau) from the series' own derivative against f(y(tau)), inside
      // the step the series would allow.
      const double h = allowed_step(e, inverse(state_scale<5>(p.motor)), 1e-6, 4.0 / omega_n);
      for (const double tau : {0.0, 0.3 * h, h}) {
        const LuGreState y = e.state(tau);
        const LuGreState f = derivative(p.motor, y, V0 + slope * tau, s, saturated);
        const LuGreState scale = state_scale<5>(p.motor);
        for (std::size_t i = 0; i < 5; ++i) {
          // The truncation (the tolerance per step, on the last order)
          // shows in the derivative as kOrder times it over the step, at
          // the step's end; the rest is rounding.
          const double truncation = 2.0 * kOrder * 1e-6 / h * std::pow(tau / h, kOrder - 1);
          EXPECT_NEAR(slope_at(e.y[i], tau), f[i], scale[i] * (1e-9 * omega_n + truncation))
              << "state " << i << " at tau = " << tau << ", s = " << s
              << (saturated ? ", saturated" : "");
        }
        EXPECT_NEAR(at(e.v, tau), y[kXDot] - p.motor.r * y[kThetaDot], 1e-12 * std::abs(y0[kXDot]));
      }
    }
  }
}

TEST(SeriesStep, TheBoundIsTheSmallerRootOfTheLastTwoOrders) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> exponent(-12.0, 12.0);
  for (int i = 0; i < 500; ++i) {
    Expansion e{};
    for (auto& c : e.y) {
      c[kOrder] = std::pow(10.0, exponent(rng));
      c[kOrder - 1] = std::pow(10.0, exponent(rng));
    }
    const LuGreState scale{1.0, 1.0, 1.0, 1.0, 1.0};
    double last = 0.0, before = 0.0;
    for (const auto& c : e.y) {
      last = std::max(last, c[kOrder]);
      before = std::max(before, c[kOrder - 1]);
    }
    const double h_max = std::pow(10.0, exponent(rng) / 4.0);
    const double expected = std::min(
        {h_max, std::pow(1e-6 / last, 1.0 / kOrder), std::pow(1e-6 / before, 1.0 / (kOrder - 1))});
    // The roots by NthRoot, to 1e-9.
    EXPECT_NEAR(allowed_step(e, scale, 1e-6, h_max), expected, 2e-9 * expected);
  }
}

TEST(SeriesZero, FirstZeroIsTheFirstSignChangeOfSv) {
  // v(tau) = (tau - r1)(tau - r2) ... as a polynomial with roots inside
  // and beyond the step; the first zero of s*v past 0 is found to 1e-12.
  for (const double s : {1.0, -1.0}) {
    for (const double r1 : {0.2, 0.55, 0.95}) {
      Coefficients v{};
      // s*v = (r1 - tau)(r1 + 2 - tau) > 0 at 0, first zero at r1.
      v[0] = s * r1 * (r1 + 2.0);
      v[1] = s * -(2.0 * r1 + 2.0);
      v[2] = s;
      EXPECT_NEAR(first_zero(v, s, 1.0), r1, 2e-12) << r1;
      EXPECT_LT(s * at(v, first_zero(v, s, 1.0)), 0.0) << "the step ends with the new sign";
    }
    // No zero in the step: the whole step.
    Coefficients v{};
    v[0] = s;
    v[1] = s * 0.1;
    EXPECT_EQ(first_zero(v, s, 1.0), 1.0);
    // A dip below zero and back inside the step (two close roots).
    Coefficients dip{};
    dip[0] = s * 0.3 * 0.32;  // (tau - 0.3)(tau - 0.32)
    dip[1] = s * -0.62;
    dip[2] = s;
    EXPECT_NEAR(first_zero(dip, s, 1.0), 0.3, 2e-12);
    // A dip whose minimum (at 0.31) stays 1e-9 above zero: no zero, the
    // whole step; 1e-9 below: its first root, 0.31 - sqrt(1e-9).
    for (const double lift : {1e-4 + 1e-9, 1e-4 - 1e-9}) {
      Coefficients near{};
      near[0] = s * (0.3 * 0.32 + lift);
      near[1] = s * -0.62;
      near[2] = s;
      const double expected = lift > 1e-4 ? 1.0 : 0.31 - std::sqrt(1e-4 - lift);
      EXPECT_NEAR(first_zero(near, s, 1.0), expected, 2e-12) << lift;
    }
  }
}

TEST(NthRoot, IsStdPowToOnePartInABillionOverTheWholeRange) {
  const NthRoot<kOrder - 1> root13;
  const NthRoot<kOrder> root14;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> exponent(-307.0, 307.0);
  for (int i = 0; i < 100000; ++i) {
    const double x = std::pow(10.0, exponent(rng));
    EXPECT_NEAR(root13(x), std::pow(x, 1.0 / (kOrder - 1)), 1e-9 * std::pow(x, 1.0 / 13)) << x;
    EXPECT_NEAR(root14(x), std::pow(x, 1.0 / kOrder), 1e-9 * std::pow(x, 1.0 / 14)) << x;
  }
  // Past the normal range, std::pow itself.
  for (const double x : {0.0, 1e-310, std::numeric_limits<double>::infinity()}) {
    EXPECT_EQ(root13(x), std::pow(x, 1.0 / 13)) << x;
  }
  EXPECT_TRUE(std::isnan(root13(std::numeric_limits<double>::quiet_NaN())));
}

}  // namespace
}  // namespace piezo::model::hybrid
