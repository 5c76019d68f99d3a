#include "piezo/hal/posix/monotonic_clock.hpp"

#include <cerrno>
#include <ctime>

namespace piezo::hal::posix {

TimeNs MonotonicClock::now() const {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<TimeNs>(ts.tv_sec) * kNsPerSecond + ts.tv_nsec;
}

void MonotonicClock::sleep_until(TimeNs t) {
  const timespec deadline{static_cast<time_t>(t / kNsPerSecond),
                          static_cast<long>(t % kNsPerSecond)};
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, nullptr) == EINTR) {
  }
}

}  // namespace piezo::hal::posix
