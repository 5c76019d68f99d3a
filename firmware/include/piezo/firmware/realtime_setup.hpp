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

/// Keeps the CPUs out of deep idle states while it lives, through
/// /dev/cpu_dma_latency (as cyclictest does): waking from them costs tens
/// of microseconds at every deadline.
class CpuLatencyRequest {
 public:
  CpuLatencyRequest();
  ~CpuLatencyRequest();
  CpuLatencyRequest(const CpuLatencyRequest&) = delete;
  CpuLatencyRequest& operator=(const CpuLatencyRequest&) = delete;
  [[nodiscard]] const RealtimeResult& result() const { return result_; }

 private:
  int fd_ = -1;
  RealtimeResult result_;
};

/// mlockall(MCL_CURRENT | MCL_FUTURE) for the whole process: no page faults later.
[[nodiscard]] RealtimeResult lock_process_memory();

/// Touches `bytes` of the calling thread's stack so its pages are resident.
void prefault_stack(std::size_t bytes = 256 * 1024);

/// Puts the calling thread under SCHED_FIFO at `priority` (1..99).
[[nodiscard]] RealtimeResult make_thread_fifo(int priority);

}  // namespace piezo::firmware
