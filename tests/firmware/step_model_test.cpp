// A move's step model: interpolation in the table, the amplitude for a
// distance, and what a measured step teaches.

#include "piezo/firmware/step_model.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace piezo::firmware {
namespace {

constexpr StepModel::Table kForward{2e-4, 4e-4, 6e-4, 8e-4, 1e-3, 1.2e-3};
constexpr StepModel::Table kReverse{1e-4, 2e-4, 3e-4, 4e-4, 5e-4, 6e-4};

TEST(StepModel, InterpolatesTheTableEachWay) {
  StepModel m;
  m.use(kForward, kReverse);
  EXPECT_DOUBLE_EQ(m.predicted(StepModel::kForward, 1.0), 1.2e-3);
  EXPECT_NEAR(m.predicted(StepModel::kForward, 0.55), 3e-4, 1e-12);
  EXPECT_DOUBLE_EQ(m.predicted(StepModel::kReverse, 0.5), 1e-4);
}

TEST(StepModel, TheFractionForADistanceMatchesItsPrediction) {
  StepModel m;
  m.use(kForward, kReverse);
  EXPECT_EQ(m.fraction_for(StepModel::kForward, 5e-3), 1.0) << "beyond a full step";
  const double f = m.fraction_for(StepModel::kForward, 7e-4);
  EXPECT_NEAR(f, 0.75, 1e-3);
  EXPECT_NEAR(m.fraction_for(StepModel::kForward, 1e-5), kStepFractions.front(), 1e-3);
}

TEST(StepModel, AMeasuredStepScalesItsDirectionOnly) {
  StepModel m;
  m.use(kForward, kReverse);
  m.learn(StepModel::kForward, 2.4e-3, 1.2e-3, 1e-4);  // twice the prediction
  EXPECT_NEAR(m.scale(StepModel::kForward), std::pow(2.0, 0.7), 1e-12);
  EXPECT_DOUBLE_EQ(m.scale(StepModel::kReverse), 1.0);
  m.learn(StepModel::kReverse, 1e-3, 5e-5, 1e-4);   // predicted below what is noticeable
  m.learn(StepModel::kReverse, -1e-4, 6e-4, 1e-4);  // went nowhere (or back)
  EXPECT_DOUBLE_EQ(m.scale(StepModel::kReverse), 1.0);
  m.use(kForward, kReverse);
  EXPECT_DOUBLE_EQ(m.scale(StepModel::kForward), 1.0) << "new tables start afresh";
}

}  // namespace
}  // namespace piezo::firmware
