#include "piezo/model/sampled_drive.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace piezo::model {
namespace {

TEST(SampledDrive, RampsToEachSampleThenHolds) {
  const std::vector<double> t{0.0, 1.0, 2.0}, V{10.0, 20.0, 0.0};
  const SampledDrive drive(t, V, 0.5);
  EXPECT_DOUBLE_EQ(drive.voltage(-1.0), 0.0);
  EXPECT_DOUBLE_EQ(drive.voltage(0.25), 5.0);   // halfway from 0 to 10
  EXPECT_DOUBLE_EQ(drive.voltage(0.75), 10.0);  // held
  EXPECT_DOUBLE_EQ(drive.voltage(1.25), 15.0);
  EXPECT_DOUBLE_EQ(drive.voltage(3.0), 0.0);
  EXPECT_DOUBLE_EQ(drive.next_breakpoint(0.1), 0.5);
  EXPECT_DOUBLE_EQ(drive.next_breakpoint(0.6), 1.0);
}

TEST(SampledDrive, AnEarlySampleCutsTheRampShort) {
  const std::vector<double> t{0.0, 0.25}, V{10.0, 10.0};
  const SampledDrive drive(t, V, 0.5);
  // The second sample arrives at 5 V and continues from there.
  EXPECT_DOUBLE_EQ(drive.voltage(0.25), 5.0);
  EXPECT_DOUBLE_EQ(drive.voltage(0.5), 7.5);
  EXPECT_DOUBLE_EQ(drive.voltage(1.0), 10.0);
}

TEST(SampledDrive, RefusesTimesThatDoNotIncrease) {
  const std::vector<double> t{0.0, 0.0}, V{1.0, 2.0};
  EXPECT_THROW(SampledDrive(t, V, 0.1), std::invalid_argument);
}

}  // namespace
}  // namespace piezo::model
