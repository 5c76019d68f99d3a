#include "piezo/model/sensitivity.hpp"

#include <gtest/gtest.h>

#include <algorithm>

namespace piezo::model {
namespace {

TEST(Elasticity, IsRelativeSpreadOverRelativeSpread) {
  // velocity proportional to the parameter: elasticity exactly 1
  EXPECT_NEAR(elasticity({1, 2, 3}, {10, 20, 30}), 1.0, 1e-12);
  // inverse influence: negative sign
  EXPECT_LT(elasticity({1, 2, 3}, {3, 2, 1}), 0.0);
  // v ~ p^2 over +/-10 %: (1.21-0.81)/0.2 = 2
  EXPECT_NEAR(elasticity({0.9, 1.0, 1.1}, {0.81, 1.0, 1.21}), 2.0, 1e-12);
}

TEST(Ranking, OrdersByMagnitude) {
  std::vector<SweepResult> r{{"a", {}, {}, 0.5}, {"b", {}, {}, -3.0}, {"c", {}, {}, 1.0}};
  EXPECT_EQ(rank_by_influence(r), (std::vector<std::string>{"b", "c", "a"}));
}

TEST(PaperSweeps, FiveLevelsWithBaselineInTheMiddle) {
  const Parameters base;
  for (const auto& s : paper_sweeps()) {
    ASSERT_EQ(s.levels.size(), 5u) << s.name;
    EXPECT_TRUE(std::is_sorted(s.levels.begin(), s.levels.end()));
    const Parameters p = with_level(base, s.name, s.levels[2]);
    EXPECT_TRUE(validate(p).empty()) << s.name;
  }
}

TEST(WithLevel, DutyRatioGoesThroughRiseFraction) {
  const Parameters p = with_level(Parameters{}, "D", 0.825);
  EXPECT_NEAR(p.drive.D(), 0.825, 1e-12);
  EXPECT_TRUE(validate(p).empty());
}

TEST(Sensitivity, SignsMatchThePaper) {
  // Velocity rises with V0, f and D and falls with mu (paper section 5).
  const Parameters base;
  const double runtime = 1.0;
  for (const auto& s : paper_sweeps()) {
    const double low =
        mean_velocity(with_level(base, s.name, s.levels.front()), FrictionModel::lugre, runtime);
    const double high =
        mean_velocity(with_level(base, s.name, s.levels.back()), FrictionModel::lugre, runtime);
    if (s.name == "mu") {
      EXPECT_LT(high, low) << s.name;
    } else {
      EXPECT_GT(high, low) << s.name;
    }
  }
}

}  // namespace
}  // namespace piezo::model
