// A sensor held to its measuring range: a reading outside it is
// out_of_range (its value kept for diagnosis), inside it passes, and a
// failed read keeps its own status.

#include "piezo/hal/range_checked_sensor.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace piezo::hal {
namespace {

class Scripted final : public DisplacementSensor {
 public:
  explicit Scripted(std::vector<DisplacementReading> readings) : readings_(std::move(readings)) {}
  DisplacementReading read() override { return readings_.at(next_++); }

 private:
  std::vector<DisplacementReading> readings_;
  std::size_t next_ = 0;
};

TEST(RangeCheckedSensor, ReadingsOutsideTheRangeAreOutOfRange) {
  Scripted inner({{0.07, 1, 2, Status::ok},
                  {3.8e33, 3, 4, Status::ok},
                  {-0.2, 5, 6, Status::ok},
                  {0.0, 7, 8, Status::timeout},
                  {0.1, 9, 10, Status::ok}});
  RangeCheckedSensor sensor(inner, -0.1, 0.1);
  EXPECT_EQ(sensor.read().status, Status::ok);
  const DisplacementReading wild = sensor.read();
  EXPECT_EQ(wild.status, Status::out_of_range);
  EXPECT_EQ(wild.displacement_m, 3.8e33);
  EXPECT_EQ(sensor.read().status, Status::out_of_range);
  EXPECT_EQ(sensor.read().status, Status::timeout);
  EXPECT_EQ(sensor.read().status, Status::ok) << "the range's ends are inside it";
}

}  // namespace
}  // namespace piezo::hal
