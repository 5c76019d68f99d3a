// Counts a GPIO output's rising edges as the kernel holds it: polls the
// gpio-sim line's sysfs value (the level the chip's consumer set) every
// 200 us, at a real-time priority just below the loops' (above it, it
// starves them under emulation; at a normal priority they keep it from
// looking for longer than a pulse), and, on SIGTERM or SIGINT, writes each rising edge's time
// (CLOCK_MONOTONIC, ns) to OUT, one per line. Runs in the qemu guest beside
// the program that drives the line: what the line did, measured outside it.
// Usage: edge_watch VALUE_FILE OUT

#include <fcntl.h>
#include <sched.h>
#include <sys/mman.h>
#include <unistd.h>

#include <csignal>
#include <cstdint>
#include <cstdio>
#include <ctime>
#include <vector>

namespace {

volatile std::sig_atomic_t g_stop = 0;

void on_signal(int) {
  g_stop = 1;
}

std::int64_t now_ns() {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<std::int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: edge_watch VALUE_FILE OUT\n");
    return 2;
  }
  const int fd = open(argv[1], O_RDONLY);
  if (fd < 0) {
    std::perror(argv[1]);
    return 1;
  }
  const sched_param below_the_loops{78};
  if (sched_setscheduler(0, SCHED_FIFO, &below_the_loops) != 0) std::perror("sched_setscheduler");
  (void)mlockall(MCL_CURRENT | MCL_FUTURE);
  std::signal(SIGTERM, on_signal);
  std::signal(SIGINT, on_signal);
  std::vector<std::int64_t> rising;
  rising.reserve(100'000);
  char last = '0';
  const timespec pause{0, 200'000};
  while (g_stop == 0) {
    char level = '0';
    if (pread(fd, &level, 1, 0) == 1) {
      if (level == '1' && last == '0') rising.push_back(now_ns());
      last = level;
    }
    nanosleep(&pause, nullptr);
  }
  std::FILE* out = std::fopen(argv[2], "w");
  if (out == nullptr) {
    std::perror(argv[2]);
    return 1;
  }
  for (const std::int64_t t : rising) std::fprintf(out, "%lld\n", static_cast<long long>(t));
  std::fclose(out);
  return 0;
}
