#pragma once
// piezod under systemd (Type=notify, WatchdogSec): READY once the hardware
// is open, a watchdog ping while the daemon and its loops make progress,
// STOPPING on the way out. Outside systemd (no NOTIFY_SOCKET) every call
// does nothing.

#include <chrono>
#include <cstdint>

namespace piezo::daemon {

class ServiceManager {
 public:
  ServiceManager();

  void ready();
  /// Pings the watchdog at half its period, no more often.
  void alive();
  void stopping();
  [[nodiscard]] bool watchdog_enabled() const { return watchdog_period_.count() > 0; }

 private:
  std::chrono::microseconds watchdog_period_{0};
  std::chrono::steady_clock::time_point last_ping_{};
};

}  // namespace piezo::daemon
