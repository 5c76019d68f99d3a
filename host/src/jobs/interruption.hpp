#pragma once
// Where a long computation may be stopped from outside: the loops that wait
// on workers (parallel_for) and the simulations' progress calls call
// interruption_point(), which throws when the one who started the work has
// asked to stop. The command line installs nothing (Ctrl-C ends the
// process); the Python package installs a check of Python's signals, so that
// KeyboardInterrupt (a notebook's interrupt) stops a study within a job.

#include <atomic>
#include <exception>

#include "piezo/model/simulate.hpp"

namespace piezo::host {

/// Throws to stop the work in progress; returns to let it go on.
using InterruptionCheck = void (*)();

inline std::atomic<InterruptionCheck> interruption_check{nullptr};

inline void set_interruption_check(InterruptionCheck check) {
  interruption_check = check;
}

/// Thrown in a parallel_for worker whose caller has stopped the jobs.
struct JobsStopped : std::exception {
  [[nodiscard]] const char* what() const noexcept override { return "stopped by the caller"; }
};

/// Set in parallel_for's worker threads: the flag their caller raises to
/// stop the jobs under way. A worker never runs the installed check itself
/// (Python's signals are for its main thread to read).
inline thread_local const std::atomic<bool>* jobs_stopped = nullptr;

inline void interruption_point() {
  if (jobs_stopped != nullptr) {
    if (jobs_stopped->load(std::memory_order_relaxed)) throw JobsStopped();
    return;
  }
  if (const InterruptionCheck check = interruption_check.load()) check();
}

/// Integrator settings whose progress calls are interruption points: a
/// study's or sweep's job then stops within milliseconds when asked, even
/// on a stiff parameter set that would take minutes.
inline model::IntegratorSettings interruptible(model::IntegratorSettings settings = {}) {
  settings.progress = [](double) { interruption_point(); };
  return settings;
}

}  // namespace piezo::host
