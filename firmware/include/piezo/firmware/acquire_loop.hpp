#pragma once
/// @file
/// The acquire loop: at its configured rate it issues one blocking read,
/// reports the outcome to the safety supervisor (through SensorHealth) and
/// pushes a timestamped SensorSample. Same rules as the drive loop: no
/// allocation, locks, exceptions or I/O beyond the HAL inside it.

#include <atomic>

#include "piezo/firmware/loop_health.hpp"
#include "piezo/firmware/position_feed.hpp"
#include "piezo/firmware/samples.hpp"
#include "piezo/firmware/sensor_health.hpp"
#include "piezo/firmware/spsc_ring.hpp"
#include "piezo/hal/clock.hpp"
#include "piezo/hal/displacement_sensor.hpp"

namespace piezo::firmware {

class AcquireLoop {
 public:
  AcquireLoop(hal::Clock& clock, hal::DisplacementSensor& sensor, double rate_hz,
              SensorHealth& sensor_health, SpscRing<SensorSample>& ring,
              PositionFeed* feed = nullptr);

  /// Samples from t0 until `stop` is set (the drive loop has finished).
  void run(hal::TimeNs t0, const std::atomic<bool>& stop);

  [[nodiscard]] LoopHealth& health() { return health_; }
  [[nodiscard]] const LoopHealth& health() const { return health_; }

 private:
  hal::Clock& clock_;
  hal::DisplacementSensor& sensor_;
  hal::TimeNs period_;
  SensorHealth& sensor_health_;
  SpscRing<SensorSample>& ring_;
  PositionFeed* feed_;  ///< good readings for a controller in the drive loop (may be null)
  LoopHealth health_;
};

}  // namespace piezo::firmware
