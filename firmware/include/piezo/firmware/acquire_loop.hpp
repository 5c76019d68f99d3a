#pragma once
/// @file
/// An acquire loop: at its configured rate it issues one blocking read per
/// sensor of one line, one after the other in the same tick, reports each
/// outcome to that axis's safety supervisor (through its SensorHealth) and
/// pushes a timestamped SensorSample to the axis's ring. A run has one such
/// loop, on a thread of its own, per sensor line (a sensor of its own, or
/// the sensors sharing a bus or a card: hal::DisplacementSensor::shared_line),
/// so a sensor that stalls slows only the axes on its line. The loops share
/// one LoopHealth (its counters and histogram take several writers). Same
/// rules as the drive loop: no allocation, locks, exceptions or I/O beyond
/// the HAL inside it.

#include <atomic>
#include <vector>

#include "piezo/firmware/loop_health.hpp"
#include "piezo/firmware/position_feed.hpp"
#include "piezo/firmware/samples.hpp"
#include "piezo/firmware/sensor_health.hpp"
#include "piezo/firmware/spsc_ring.hpp"
#include "piezo/hal/clock.hpp"
#include "piezo/hal/displacement_sensor.hpp"

namespace piezo::firmware {

/// One axis's sensor and where its readings go; all outlive the loop.
struct AcquireAxis {
  hal::DisplacementSensor* sensor = nullptr;
  SensorHealth* health = nullptr;
  SpscRing<SensorSample>* ring = nullptr;
  PositionFeed* feed = nullptr;  ///< good readings for a controller in the drive loop (may be null)
  std::uint8_t index = 0;        ///< the board's axis, written on its records
};

class AcquireLoop {
 public:
  /// `axes` holds at least one axis; `health` outlives the loop.
  AcquireLoop(hal::Clock& clock, std::vector<AcquireAxis> axes, double rate_hz,
              LoopHealth& health);

  /// Samples from t0 until `stop` is set (the drive loop has finished).
  void run(hal::TimeNs t0, const std::atomic<bool>& stop);

  [[nodiscard]] const LoopHealth& health() const { return health_; }

 private:
  void read(const AcquireAxis& axis);

  hal::Clock& clock_;
  std::vector<AcquireAxis> axes_;
  hal::TimeNs period_;
  LoopHealth& health_;
};

}  // namespace piezo::firmware
