#include "piezo/hal/sim/virtual_clock.hpp"

#include <algorithm>
#include <chrono>
#include <thread>

namespace piezo::hal::sim {

VirtualClock::VirtualClock(TimeNs start) : now_(start) {
  sleepers_.reserve(16);
}

TimeNs VirtualClock::now() const {
  std::lock_guard lock(mutex_);
  return now_;
}

void VirtualClock::add_sleeper() {
  std::lock_guard lock(mutex_);
  ++running_;
}

void VirtualClock::remove_sleeper() {
  std::lock_guard lock(mutex_);
  --running_;
  schedule_next_locked();
}

void VirtualClock::set_backpressure(std::function<bool()> lagging) {
  lagging_ = std::move(lagging);
}

void VirtualClock::sleep_until(TimeNs t) {
  // Virtual time costs nothing; let the consumer catch up first. Only this
  // thread runs meanwhile, so the schedule stays the same.
  if (lagging_) {
    while (lagging_()) std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  std::unique_lock lock(mutex_);
  const std::uint64_t ticket = next_ticket_++;
  sleepers_.push_back({t, ticket});
  --running_;
  schedule_next_locked();
  wakeup_.wait(lock, [&] { return released_ == ticket; });
  released_ = UINT64_MAX;
}

void VirtualClock::schedule_next_locked() {
  if (running_ > 0 || sleepers_.empty() || released_ != UINT64_MAX) return;
  const auto earliest = std::min_element(sleepers_.begin(), sleepers_.end(), [](auto& a, auto& b) {
    return a.wake != b.wake ? a.wake < b.wake : a.ticket < b.ticket;
  });
  now_ = std::max(now_, earliest->wake);
  released_ = earliest->ticket;
  sleepers_.erase(earliest);
  ++running_;
  wakeup_.notify_all();
}

}  // namespace piezo::hal::sim
