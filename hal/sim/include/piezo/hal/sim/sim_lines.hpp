#pragma once
/// @file
/// Simulated digital lines: amplifier enable goes to the plant's amplifier,
/// sync pulses are counted, and the e-stop can be pressed at a set time.

#include <atomic>
#include <limits>

#include "piezo/hal/clock.hpp"
#include "piezo/hal/digital_lines.hpp"
#include "piezo/hal/sim/plant.hpp"

namespace piezo::hal::sim {

struct SimLinesSettings {
  /// The e-stop is pressed this long after t0 (never by default).
  double estop_at_s = std::numeric_limits<double>::infinity();
};

class SimLines final : public DigitalLines {
 public:
  SimLines(const SimLinesSettings& settings, Plant& plant, const Clock& clock, TimeNs t0);

  Status set_amplifier_enable(bool enabled) override;
  Status set_sync(bool high) override;
  [[nodiscard]] EstopState poll_estop() override;
  bool trip() override;

  /// Presses the e-stop now (any thread): the next poll sees an edge.
  void press_estop() { estop_pressed_.store(true, std::memory_order_release); }
  [[nodiscard]] long sync_pulses() const { return sync_pulses_.load(); }
  /// Moves the time origin of estop_at_s, before the run starts.
  void set_time_origin(TimeNs t0) { t0_ = t0; }

 private:
  SimLinesSettings settings_;
  Plant& plant_;
  const Clock& clock_;
  TimeNs t0_;
  bool sync_ = false;
  bool estop_reported_ = false;
  std::atomic<bool> estop_pressed_{false};
  std::atomic<long> sync_pulses_{0};
};

}  // namespace piezo::hal::sim
