#pragma once
/// @file
/// A loop's health as data: counters the host may read live (atomics,
/// relaxed) and the period-error histogram it reads after the loop ends.

#include <atomic>
#include <cstdint>

#include "piezo/firmware/period_histogram.hpp"

namespace piezo::firmware {

struct LoopHealth {
  std::atomic<std::uint64_t> cycles{0};
  std::atomic<std::uint64_t> overruns{0};         ///< cycles whose work ran past the next deadline
  std::atomic<std::uint64_t> missed_cycles{0};    ///< deadlines passed during an overrun
  std::atomic<std::uint64_t> dropped_samples{0};  ///< ring full
  std::atomic<std::uint64_t> errors{0};           ///< HAL calls that did not return ok
  /// Written by the loop only; read once the loop has ended.
  PeriodHistogram period_error;

  void count(std::atomic<std::uint64_t>& counter, std::uint64_t n = 1) {
    counter.fetch_add(n, std::memory_order_relaxed);
  }
};

/// Advances `deadline` past `now` in whole periods; returns how many it passed.
/// The acquire loop skips them (a reading belongs to when it is taken); the
/// drive loop only counts them and writes each passed deadline's value late,
/// catching up (a clocked output needs every tick's value: DriveLoop::count_lateness).
inline std::uint64_t skip_missed(hal::TimeNs& deadline, hal::TimeNs now, hal::TimeNs period) {
  if (now < deadline) return 0;
  const auto missed = static_cast<std::uint64_t>((now - deadline) / period) + 1;
  deadline += static_cast<hal::TimeNs>(missed) * period;
  return missed;
}

}  // namespace piezo::firmware
