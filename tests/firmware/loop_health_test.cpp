#include "piezo/firmware/loop_health.hpp"

#include <gtest/gtest.h>

#include "piezo/firmware/voltage_limiter.hpp"

namespace piezo::firmware {
namespace {

TEST(PeriodHistogram, QuantilesAndMaximum) {
  PeriodHistogram h;
  for (int i = 0; i < 98; ++i) h.record(10'500);  // 10.5 us
  h.record(50'000);
  h.record(3'000'000);  // 3 ms: beyond the last bin
  EXPECT_EQ(h.count(), 100u);
  EXPECT_DOUBLE_EQ(h.quantile_us(0.5), 11.0);  // upper edge of the 10 us bin
  EXPECT_DOUBLE_EQ(h.quantile_us(0.99), 51.0);
  EXPECT_DOUBLE_EQ(h.max_us(), 3000.0);
  EXPECT_EQ(h.bins()[PeriodHistogram::kBins - 1], 1u);
}

TEST(PeriodHistogram, EarlyWakeUpsCountAsZero) {
  PeriodHistogram h;
  h.record(-5'000);
  EXPECT_EQ(h.bins()[0], 1u);
  EXPECT_DOUBLE_EQ(h.max_us(), 0.0);
}

TEST(SkipMissed, SkipsWholePeriodsPastNow) {
  hal::TimeNs deadline = 1000;
  EXPECT_EQ(skip_missed(deadline, 999, 100), 0u);
  EXPECT_EQ(deadline, 1000);
  EXPECT_EQ(skip_missed(deadline, 1000, 100), 1u);  // a deadline met exactly at its end is gone
  EXPECT_EQ(deadline, 1100);
  EXPECT_EQ(skip_missed(deadline, 1350, 100), 3u);
  EXPECT_EQ(deadline, 1400);
}

TEST(VoltageLimiter, ClampsToTheRangeThenLimitsTheSlew) {
  const VoltageLimits limits{0.0, 80.0, 1000.0};
  EXPECT_DOUBLE_EQ(limit_voltage(limits, 50.0, 49.95, 1e-4), 50.0);
  EXPECT_DOUBLE_EQ(limit_voltage(limits, 50.0, 40.0, 1e-4), 40.1);
  EXPECT_DOUBLE_EQ(limit_voltage(limits, 95.0, 79.95, 1e-4), 80.0);
  EXPECT_DOUBLE_EQ(limit_voltage(limits, -5.0, 0.05, 1e-4), 0.0);
  EXPECT_DOUBLE_EQ(step_towards(10.0, 0.0, 1000.0, 1e-3), 9.0);
}

}  // namespace
}  // namespace piezo::firmware
