#pragma once
// Every signal a user or the terminal can send while the drive runs ends
// the run the same way: the handler only records which signal came, the
// host loop asks the firmware to stop, and the drive ramps to 0 V and is
// disabled like on SIGINT. Signals whose default would stop the process
// for a reason that is no reason to stop the drive (a closed pipe, a full
// file, a background terminal write) are ignored: the failing write then
// returns an error that the caller handles or drops.

#include <atomic>
#include <string>

namespace piezo::host {

/// Installs the handlers for its lifetime and restores the previous ones.
class StopOnSignals {
 public:
  StopOnSignals();
  ~StopOnSignals();
  StopOnSignals(const StopOnSignals&) = delete;
  StopOnSignals& operator=(const StopOnSignals&) = delete;

  /// Stops the run as a signal would (e.g. the web view's stop button).
  void request_stop() const;
  /// Set once any stopping signal has arrived.
  [[nodiscard]] const std::atomic<bool>& flag() const;
  /// The first stopping signal's name ("SIGHUP"), or "" while none came.
  [[nodiscard]] std::string received() const;
};

}  // namespace piezo::host
