#pragma once
/// @file
/// A virtual clock that runs the loops faster than real time and
/// deterministically: the announced threads take turns, exactly one runs at
/// a time, and time jumps to the earliest deadline once all of them sleep.
/// Ties wake in the order the sleeps were requested.
///
/// It blocks on a mutex and condition variable: a simulation device, not part
/// of the firmware, and the price of a reproducible schedule.

#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <vector>

#include "piezo/hal/clock.hpp"

namespace piezo::hal::sim {

class VirtualClock final : public Clock {
 public:
  explicit VirtualClock(TimeNs start = 0);

  [[nodiscard]] TimeNs now() const override;
  void sleep_until(TimeNs t) override;
  void add_sleeper() override;
  void remove_sleeper() override;
  void set_backpressure(std::function<bool()> lagging) override;

 private:
  struct Sleeper {
    TimeNs wake;
    std::uint64_t ticket;
  };
  // Called with the mutex held when a running thread stops running.
  void schedule_next_locked();

  mutable std::mutex mutex_;
  std::condition_variable wakeup_;
  TimeNs now_;
  int running_ = 0;  // announced threads not asleep
  std::uint64_t next_ticket_ = 0;
  std::uint64_t released_ = UINT64_MAX;  // ticket allowed to run
  std::vector<Sleeper> sleepers_;        // reserved up front; a handful of threads
  std::function<bool()> lagging_;        // set before the sleepers start
};

}  // namespace piezo::hal::sim
