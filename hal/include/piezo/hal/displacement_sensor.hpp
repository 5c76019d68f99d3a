#pragma once
/// @file
/// The displacement sensor (a laser triangulation sensor on the rig).

#include <string>

#include "piezo/hal/clock.hpp"
#include "piezo/hal/status.hpp"

namespace piezo::hal {

struct DisplacementReading {
  double displacement_m = 0.0;
  TimeNs t_request = 0;   ///< when the read was issued
  TimeNs t_response = 0;  ///< when its answer arrived
  Status status = Status::ok;
};

class DisplacementSensor {
 public:
  DisplacementSensor() = default;
  DisplacementSensor(const DisplacementSensor&) = delete;
  DisplacementSensor& operator=(const DisplacementSensor&) = delete;
  virtual ~DisplacementSensor() = default;

  /// One blocking read, bounded by the backend's timeout. Called from the
  /// acquire loop: no allocation, no exceptions.
  [[nodiscard]] virtual DisplacementReading read() = 0;

  /// The line its reads go over when other sensors share it and must be
  /// read one after another, from one thread (an RS-485 bus, one card's
  /// input): those sensors are read in one loop, in turn. Empty: a line of
  /// its own, read on its own clock, so a sensor that stalls costs no
  /// other axis its readings.
  [[nodiscard]] virtual std::string shared_line() const { return {}; }
};

}  // namespace piezo::hal
