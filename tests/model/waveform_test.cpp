#include "piezo/model/waveform.hpp"

#include <gtest/gtest.h>

namespace piezo::model {
namespace {

TEST(Sawtooth, RisesLinearlyOverDTThenFallsToZero) {
  const Sawtooth s(80.0, 10.0, 0.75);  // T = 0.1 s, peak at 0.075 s
  EXPECT_DOUBLE_EQ(s.voltage(0.0), 0.0);
  EXPECT_DOUBLE_EQ(s.voltage(0.0375), 40.0);
  EXPECT_NEAR(s.voltage(0.075 - 1e-12), 80.0, 1e-6);
  EXPECT_NEAR(s.voltage(0.075), 80.0, 1e-9);
  EXPECT_NEAR(s.voltage(0.0875), 40.0, 1e-9);
  EXPECT_NEAR(s.voltage(0.1 - 1e-12), 0.0, 1e-6);
}

TEST(Sawtooth, IsPeriodic) {
  const Sawtooth s(80.0, 20.0, 0.74955);
  for (double t : {0.001, 0.013, 0.04, 0.049}) {
    EXPECT_NEAR(s.voltage(t), s.voltage(t + 3 * s.period()), 1e-9) << t;
  }
}

TEST(Sawtooth, StaysWithinZeroAndPeak) {
  const Sawtooth s(72.0, 12.0, 0.675);
  for (int i = 0; i < 10000; ++i) {
    const double v = s.voltage(i * 1.7e-4);
    EXPECT_GE(v, -1e-12);
    EXPECT_LE(v, 72.0 + 1e-12);
  }
}

TEST(Sawtooth, BreakpointsAreThePeaksAndPeriodStarts) {
  const Sawtooth s(80.0, 10.0, 0.75);
  EXPECT_DOUBLE_EQ(s.next_breakpoint(0.0), 0.075);
  EXPECT_NEAR(s.next_breakpoint(0.075), 0.1, 1e-15);
  EXPECT_NEAR(s.next_breakpoint(0.1), 0.175, 1e-12);
  EXPECT_NEAR(s.next_breakpoint(0.05), 0.075, 1e-15);
  EXPECT_NEAR(s.next_breakpoint(0.09), 0.1, 1e-15);
}

}  // namespace
}  // namespace piezo::model
