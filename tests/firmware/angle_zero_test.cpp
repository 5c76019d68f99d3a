// The angle's zero: one rule for the board, a move and the host's log.

#include "piezo/firmware/angle_zero.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace piezo::firmware {
namespace {

TEST(AngleZero, IsTheFirstGoodReadingAndThenStays) {
  AngleZero zero;
  EXPECT_FALSE(zero.known());
  EXPECT_TRUE(std::isnan(zero.angle_rad(0.07, 0.062)));
  zero.offer(0.07);
  ASSERT_TRUE(zero.known());
  zero.offer(0.08);
  EXPECT_EQ(zero.displacement_m(), 0.07) << "later readings do not move it";
  EXPECT_NEAR(zero.angle_rad(0.07 + 0.062e-3, 0.062), 1e-3, 1e-12);
}

TEST(AngleZero, ASetZeroWins) {
  AngleZero zero;
  zero.offer(5.0);
  zero.set(0.07);
  zero.offer(9.0);
  EXPECT_EQ(zero.displacement_m(), 0.07);
  EXPECT_EQ(AngleZero(0.05).displacement_m(), 0.05);
  EXPECT_FALSE(AngleZero(std::nan("")).known());
}

}  // namespace
}  // namespace piezo::firmware
