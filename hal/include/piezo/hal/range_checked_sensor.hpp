#pragma once
/// @file
/// A displacement sensor held to its measuring range: a reading outside it
/// (a word-order mistake, a spike, a sensor that lost its target) is
/// `out_of_range`, never a displacement. The acquire loop counts it as a
/// sensor error, the log keeps its status, and nothing downstream (the
/// move controller, the observer) takes it for an angle.

#include "piezo/hal/displacement_sensor.hpp"

namespace piezo::hal {

class RangeCheckedSensor final : public DisplacementSensor {
 public:
  /// `inner` outlives this; readings in [min_m, max_m] pass.
  RangeCheckedSensor(DisplacementSensor& inner, double min_m, double max_m)
      : inner_(inner), min_m_(min_m), max_m_(max_m) {}

  [[nodiscard]] DisplacementReading read() override {
    DisplacementReading r = inner_.read();
    if (r.status == Status::ok && !(r.displacement_m >= min_m_ && r.displacement_m <= max_m_)) {
      r.status = Status::out_of_range;
    }
    return r;
  }
  [[nodiscard]] std::string shared_line() const override { return inner_.shared_line(); }

 private:
  DisplacementSensor& inner_;
  double min_m_, max_m_;
};

}  // namespace piezo::hal
