#include "service_manager.hpp"

#include <systemd/sd-daemon.h>

namespace piezo::daemon {

ServiceManager::ServiceManager() {
  std::uint64_t usec = 0;
  if (sd_watchdog_enabled(0, &usec) > 0) watchdog_period_ = std::chrono::microseconds(usec);
}

void ServiceManager::ready() {
  (void)sd_notify(0, "READY=1\nSTATUS=hardware open, serving");
}

void ServiceManager::alive() {
  if (!watchdog_enabled()) return;
  const auto now = std::chrono::steady_clock::now();
  if (now - last_ping_ < watchdog_period_ / 2) return;
  last_ping_ = now;
  (void)sd_notify(0, "WATCHDOG=1");
}

void ServiceManager::stopping() {
  (void)sd_notify(0, "STOPPING=1");
}

}  // namespace piezo::daemon
