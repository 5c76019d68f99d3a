// A settle's sliding mean: the last n readings, and widening that keeps
// the readings it already holds.

#include "piezo/firmware/settle_mean.hpp"

#include <gtest/gtest.h>

namespace piezo::firmware {
namespace {

TEST(SettleMean, IsTheMeanOfTheLastNReadings) {
  SettleMean m;
  m.start(4);
  EXPECT_FALSE(m.add(1.0));
  EXPECT_FALSE(m.add(2.0));
  EXPECT_FALSE(m.add(3.0));
  EXPECT_TRUE(m.add(4.0));
  EXPECT_DOUBLE_EQ(m.mean(), 2.5);
  EXPECT_TRUE(m.add(10.0));
  EXPECT_DOUBLE_EQ(m.mean(), (2.0 + 3.0 + 4.0 + 10.0) / 4);
}

TEST(SettleMean, WideningKeepsTheReadingsHeldAndStopsAtTheMost) {
  SettleMean m;
  m.start(2);
  for (double d : {1.0, 2.0, 3.0, 4.0}) (void)m.add(d);
  ASSERT_TRUE(m.widen());
  EXPECT_EQ(m.readings(), 4);
  EXPECT_DOUBLE_EQ(m.mean(), 2.5) << "the four readings the ring still held";
  m.start(SettleMean::kMax);
  EXPECT_FALSE(m.widen());
  m.start(1000);
  EXPECT_EQ(m.readings(), SettleMean::kMax);
}

}  // namespace
}  // namespace piezo::firmware
