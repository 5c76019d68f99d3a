#pragma once
/// @file
/// A sensor that answers every read at once with a fixed displacement: for
/// checks of the loops and the lines where no plant moves (gpio-sim, the
/// loop benchmark). The safety supervisor sees a healthy sensor.

#include "piezo/hal/clock.hpp"
#include "piezo/hal/displacement_sensor.hpp"

namespace piezo::hal::sim {

class NullSensor final : public DisplacementSensor {
 public:
  explicit NullSensor(const Clock& clock, double displacement_m = 0.0)
      : clock_(clock), displacement_m_(displacement_m) {}

  [[nodiscard]] DisplacementReading read() override {
    const TimeNs now = clock_.now();
    return {displacement_m_, now, now, Status::ok};
  }

 private:
  const Clock& clock_;
  double displacement_m_;
};

}  // namespace piezo::hal::sim
