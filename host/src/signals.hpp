#pragma once
// SIGINT and SIGTERM ask a run to stop: the handler only sets a flag that
// the host loop watches, and the drive then ramps down like any other stop.

#include <atomic>

namespace piezo::host {

/// Installs the handlers for its lifetime and restores the previous ones.
class StopOnSignals {
 public:
  StopOnSignals();
  ~StopOnSignals();
  StopOnSignals(const StopOnSignals&) = delete;
  StopOnSignals& operator=(const StopOnSignals&) = delete;

  [[nodiscard]] const std::atomic<bool>& flag() const;
};

}  // namespace piezo::host
