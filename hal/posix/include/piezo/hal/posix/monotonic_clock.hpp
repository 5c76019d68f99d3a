#pragma once
/// @file
/// The rig's clock: CLOCK_MONOTONIC with absolute-deadline sleeps.

#include "piezo/hal/clock.hpp"

namespace piezo::hal::posix {

class MonotonicClock final : public Clock {
 public:
  [[nodiscard]] TimeNs now() const override;
  /// clock_nanosleep(TIMER_ABSTIME), resumed after signals: no drift, no early wake.
  void sleep_until(TimeNs t) override;
};

}  // namespace piezo::hal::posix
