#pragma once
/// @file
/// Real-time set-up, done before a loop starts: memory locked, stack
/// prefaulted, SCHED_FIFO when permitted. Where the system refuses, the run
/// goes on with a warning that is printed and recorded in the log.

#include <cstddef>
#include <string>

namespace piezo::firmware {

struct RealtimeResult {
  bool ok = false;
  std::string note;  ///< what was done, or the warning
};

/// mlockall(MCL_CURRENT | MCL_FUTURE) for the whole process: no page faults later.
[[nodiscard]] RealtimeResult lock_process_memory();

/// Touches `bytes` of the calling thread's stack so its pages are resident.
void prefault_stack(std::size_t bytes = 256 * 1024);

/// Puts the calling thread under SCHED_FIFO at `priority` (1..99).
[[nodiscard]] RealtimeResult make_thread_fifo(int priority);

}  // namespace piezo::firmware
