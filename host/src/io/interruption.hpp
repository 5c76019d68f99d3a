#pragma once
// Where a long computation may be stopped from outside: the loops that wait
// on workers (parallel_for) and the simulations' progress calls call
// interruption_point(), which throws when the one who started the work has
// asked to stop. The command line installs nothing (Ctrl-C ends the
// process); the Python package installs a check of Python's signals, so that
// KeyboardInterrupt (a notebook's interrupt) stops a study within a job.

#include <atomic>

namespace piezo::host {

/// Throws to stop the work in progress; returns to let it go on.
using InterruptionCheck = void (*)();

inline std::atomic<InterruptionCheck> interruption_check{nullptr};

inline void set_interruption_check(InterruptionCheck check) {
  interruption_check = check;
}

inline void interruption_point() {
  if (const InterruptionCheck check = interruption_check.load()) check();
}

}  // namespace piezo::host
