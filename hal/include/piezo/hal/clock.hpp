#pragma once
/// @file
/// Time for the real-time loops: CLOCK_MONOTONIC on the rig, a virtual clock
/// in simulation so that tests run faster than real time and reproducibly.

#include <cstdint>
#include <functional>

namespace piezo::hal {

/// Nanoseconds on the clock's own time line.
using TimeNs = std::int64_t;

inline constexpr TimeNs kNsPerSecond = 1'000'000'000;

[[nodiscard]] constexpr double to_seconds(TimeNs t) {
  return static_cast<double>(t) * 1e-9;
}
[[nodiscard]] constexpr TimeNs from_seconds(double s) {
  return static_cast<TimeNs>(s * 1e9 + (s >= 0 ? 0.5 : -0.5));
}

class Clock {
 public:
  Clock() = default;
  Clock(const Clock&) = delete;
  Clock& operator=(const Clock&) = delete;
  virtual ~Clock() = default;

  /// Current time. Real-time safe.
  [[nodiscard]] virtual TimeNs now() const = 0;
  /// Blocks until now() >= t (absolute deadline). Real-time safe.
  virtual void sleep_until(TimeNs t) = 0;

  /// Each thread that will sleep on this clock is announced before it starts
  /// and withdrawn when it ends: a virtual clock advances only while every
  /// announced thread sleeps. No-ops on a real clock.
  virtual void add_sleeper() {}
  virtual void remove_sleeper() {}

  /// For a clock that runs ahead of real time: while `lagging()` is true,
  /// sleepers wait in real time before time moves on, so that a consumer
  /// of their output keeps up and nothing is dropped. No-op on a real clock.
  virtual void set_backpressure(std::function<bool()> lagging) { (void)lagging; }
};

/// Announces one sleeping thread to a clock for the lifetime of this object.
/// Create it before the thread starts; the thread's body owns and ends it.
class SleeperScope {
 public:
  explicit SleeperScope(Clock& clock) : clock_(&clock) { clock_->add_sleeper(); }
  SleeperScope(SleeperScope&& o) noexcept : clock_(o.clock_) { o.clock_ = nullptr; }
  SleeperScope(const SleeperScope&) = delete;
  SleeperScope& operator=(const SleeperScope&) = delete;
  SleeperScope& operator=(SleeperScope&&) = delete;
  ~SleeperScope() {
    if (clock_ != nullptr) clock_->remove_sleeper();
  }

 private:
  Clock* clock_;
};

}  // namespace piezo::hal
