#include "piezo/model/global_sensitivity.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace piezo::model {
namespace {

constexpr double kPi = std::numbers::pi;

double ishigami(const std::vector<double>& x) {
  return std::sin(x[0]) + 7.0 * std::pow(std::sin(x[1]), 2) +
         0.1 * std::pow(x[2], 4) * std::sin(x[0]);
}

// The Ishigami function (a = 7, b = 0.1) has analytic indices:
// S = (0.3139, 0.4424, 0), ST = (0.5576, 0.4424, 0.2437).
TEST(SobolIndices, IshigamiMatchesItsAnalyticIndices) {
  const std::vector<Factor> f{{"x1", -kPi, kPi}, {"x2", -kPi, kPi}, {"x3", -kPi, kPi}};
  constexpr std::size_t n = 8192;
  const auto rows = saltelli_design(f, n);
  ASSERT_EQ(rows.size(), n * 5);
  std::vector<double> y;
  for (const auto& r : rows) y.push_back(ishigami(r));
  const SobolIndices s = sobol_indices(y, n, 3, n, 200, 1);
  const double first[3] = {0.3139, 0.4424, 0.0}, total[3] = {0.5576, 0.4424, 0.2437};
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(s.first[i], first[i], 0.02) << "S" << i + 1;
    EXPECT_NEAR(s.total[i], total[i], 0.02) << "ST" << i + 1;
    EXPECT_LE(s.first_low[i], s.first[i]);
    EXPECT_GE(s.first_high[i], s.first[i]);
    EXPECT_LT(s.first_low[i], first[i] + 0.01);
    EXPECT_GT(s.first_high[i], first[i] - 0.01);
  }
  // Fewer points, wider intervals: the convergence plot's premise.
  const SobolIndices coarse = sobol_indices(y, n, 3, n / 16, 200, 1);
  EXPECT_GT(coarse.total_high[2] - coarse.total_low[2], s.total_high[2] - s.total_low[2]);
}

// Sobol's g-function: the smaller a_i, the more important x_i. Morris's mu*
// must rank the factors in that order.
TEST(Morris, MuStarRanksTheGFunctionsFactors) {
  const std::vector<double> a{0.0, 1.0, 4.5, 9.0, 99.0};
  std::vector<Factor> f;
  for (std::size_t i = 0; i < a.size(); ++i) f.push_back({"x" + std::to_string(i), 0.0, 1.0});
  const MorrisDesign d = morris_design(f, 60, 7);
  ASSERT_EQ(d.rows.size(), 60 * (a.size() + 1));
  std::vector<double> y;
  for (const auto& x : d.rows) {
    double g = 1.0;
    for (std::size_t i = 0; i < a.size(); ++i)
      g *= (std::abs(4.0 * x[i] - 2.0) + a[i]) / (1.0 + a[i]);
    y.push_back(g);
  }
  const MorrisIndices m = morris_indices(d, a.size(), y);
  for (std::size_t i = 0; i + 1 < a.size(); ++i) {
    EXPECT_GT(m.mu_star[i], m.mu_star[i + 1]) << "x" << i << " before x" << i + 1;
  }
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_GE(m.mu_star[i], std::abs(m.mu[i]) - 1e-12);
}

// Every Morris step moves exactly one factor, by the grid's step.
TEST(Morris, EachStepMovesOneFactor) {
  const std::vector<Factor> f{{"a", 0.0, 1.0}, {"b", 10.0, 20.0}, {"c", -1.0, 1.0}};
  const MorrisDesign d = morris_design(f, 5, 3);
  for (std::size_t t = 0; t < 5; ++t) {
    for (std::size_t s = 0; s < 3; ++s) {
      const auto& before = d.rows[t * 4 + s];
      const auto& after = d.rows[t * 4 + s + 1];
      int changed = 0;
      for (std::size_t i = 0; i < 3; ++i) changed += before[i] != after[i];
      EXPECT_EQ(changed, 1);
      const std::size_t i = d.moved[t * 3 + s];
      EXPECT_NEAR((after[i] - before[i]) / (f[i].high - f[i].low), d.delta[t * 3 + s], 1e-12);
    }
  }
}

}  // namespace
}  // namespace piezo::model
