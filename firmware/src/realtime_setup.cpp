#include "piezo/firmware/realtime_setup.hpp"

#include <fcntl.h>
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <string>

namespace piezo::firmware {

CpuLatencyRequest::CpuLatencyRequest() {
  fd_ = open("/dev/cpu_dma_latency", O_WRONLY | O_CLOEXEC);
  const std::int32_t zero = 0;
  if (fd_ < 0 || write(fd_, &zero, sizeof zero) != static_cast<ssize_t>(sizeof zero)) {
    result_ = {false, std::string("CPU idle states not limited: /dev/cpu_dma_latency: ") +
                          std::strerror(errno)};
    if (fd_ >= 0) close(fd_);
    fd_ = -1;
    return;
  }
  result_ = {true, "CPU idle latency held at 0 us"};
}

CpuLatencyRequest::~CpuLatencyRequest() {
  if (fd_ >= 0) close(fd_);  // closing releases the request
}

RealtimeResult lock_process_memory() {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  // The sanitizers reserve terabytes of shadow memory; locking it would exhaust RAM.
  return {false, "memory not locked: sanitizer build"};
#else
  if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0) {
    return {false, std::string("memory not locked: mlockall: ") + std::strerror(errno)};
  }
  return {true, "memory locked"};
#endif
}

void prefault_stack(std::size_t bytes) {
  // A volatile buffer the compiler cannot elide; each page is written once.
  auto* buffer = static_cast<volatile unsigned char*>(__builtin_alloca(bytes));
  for (std::size_t i = 0; i < bytes; i += 4096) buffer[i] = 0;
}

RealtimeResult make_thread_fifo(int priority) {
  sched_param param{};
  param.sched_priority = priority;
  if (const int err = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param); err != 0) {
    return {false, "SCHED_FIFO " + std::to_string(priority) + " refused (" + std::strerror(err) +
                       "): running at normal priority"};
  }
  return {true, "SCHED_FIFO " + std::to_string(priority)};
}

}  // namespace piezo::firmware
