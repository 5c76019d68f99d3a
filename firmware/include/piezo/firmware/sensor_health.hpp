#pragma once
/// @file
/// What the acquire loop tells the safety supervisor about the sensor,
/// through atomics: the drive loop must never wait on the acquire loop.

#include <atomic>
#include <cstdint>

#include "piezo/hal/clock.hpp"

namespace piezo::firmware {

struct SensorHealth {
  std::atomic<hal::TimeNs> last_good{0};  ///< answer time of the last good reading
  std::atomic<std::uint32_t> consecutive_errors{0};

  void report(bool good, hal::TimeNs t_response) {
    if (good) {
      last_good.store(t_response, std::memory_order_release);
      consecutive_errors.store(0, std::memory_order_relaxed);
    } else {
      consecutive_errors.fetch_add(1, std::memory_order_relaxed);
    }
  }
};

}  // namespace piezo::firmware
