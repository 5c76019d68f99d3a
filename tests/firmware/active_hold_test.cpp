// The active hold's record: its end, and the errors while it held.

#include "piezo/firmware/active_hold.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace piezo::firmware {
namespace {

TEST(ActiveHold, EndsAfterItsTimeAndRecordsTheErrors) {
  ActiveHold hold;
  EXPECT_TRUE(std::isnan(hold.rms_error_rad()) && std::isnan(hold.max_error_rad()));
  hold.start(2.0, 0.5);
  EXPECT_FALSE(hold.over(2.49));
  EXPECT_TRUE(hold.over(2.5));
  hold.record(3e-6);
  hold.record(-4e-6);
  EXPECT_DOUBLE_EQ(hold.rms_error_rad(), std::sqrt((9e-12 + 16e-12) / 2.0));
  EXPECT_DOUBLE_EQ(hold.max_error_rad(), 4e-6);
  // A second hold starts its record afresh.
  hold.start(5.0, 1.0);
  hold.record(1e-6);
  EXPECT_DOUBLE_EQ(hold.rms_error_rad(), 1e-6);
  EXPECT_DOUBLE_EQ(hold.max_error_rad(), 1e-6);
}

}  // namespace
}  // namespace piezo::firmware
