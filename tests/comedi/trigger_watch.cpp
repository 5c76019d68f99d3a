// A scan's trigger on a DAQ card's digital output, seen from outside the
// program that drives it, in the qemu guest of tests/comedi/test_scan_trigger.py:
//   trigger_watch attach DEVICE         attaches comedi_parport to DEVICE at
//                                       I/O base 0x378 (qemu's parallel port),
//                                       as comedi_config does
//   trigger_watch watch DEVICE CHANNEL OUT
//                                       polls the port's data register (its
//                                       lines read back as written) every
//                                       200 us, at a real-time priority just
//                                       below the loops', and on SIGTERM
//                                       writes each rising edge of CHANNEL
//                                       (CLOCK_MONOTONIC, ns) to OUT

#include <comedilib.h>
#include <fcntl.h>
#include <sched.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>
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

int attach(const char* device) {
  const int fd = ::open(device, O_RDWR);
  if (fd < 0) {
    std::perror(device);
    return 1;
  }
  comedi_devconfig config{};
  std::strncpy(config.board_name, "comedi_parport", sizeof config.board_name - 1);
  config.options[0] = 0x378;
  const bool ok = ::ioctl(fd, COMEDI_DEVCONFIG, &config) == 0;
  if (!ok) std::perror("COMEDI_DEVCONFIG");
  ::close(fd);
  return ok ? 0 : 1;
}

int watch(const char* device, unsigned channel, const char* out_path) {
  comedi_t* card = comedi_open(device);
  if (card == nullptr) {
    comedi_perror(device);
    return 1;
  }
  const sched_param below_the_loops{78};
  if (sched_setscheduler(0, SCHED_FIFO, &below_the_loops) != 0) std::perror("sched_setscheduler");
  (void)mlockall(MCL_CURRENT | MCL_FUTURE);
  std::signal(SIGTERM, on_signal);
  std::signal(SIGINT, on_signal);
  std::vector<std::int64_t> rising;
  rising.reserve(100'000);
  unsigned last = 0;
  const timespec pause{0, 200'000};
  while (g_stop == 0) {
    unsigned bits = 0;
    if (comedi_dio_bitfield2(card, 0, 0, &bits, 0) >= 0) {
      const unsigned level = (bits >> channel) & 1u;
      if (level == 1 && last == 0) rising.push_back(now_ns());
      last = level;
    }
    nanosleep(&pause, nullptr);
  }
  comedi_close(card);
  std::FILE* out = std::fopen(out_path, "w");
  if (out == nullptr) {
    std::perror(out_path);
    return 1;
  }
  for (const std::int64_t t : rising) std::fprintf(out, "%lld\n", static_cast<long long>(t));
  std::fclose(out);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string mode = argc > 1 ? argv[1] : "";
  if (mode == "attach" && argc == 3) return attach(argv[2]);
  if (mode == "watch" && argc == 5) {
    return watch(argv[2], static_cast<unsigned>(std::strtoul(argv[3], nullptr, 10)), argv[4]);
  }
  std::fprintf(stderr, "usage: trigger_watch attach DEVICE | watch DEVICE CHANNEL OUT\n");
  return 2;
}
