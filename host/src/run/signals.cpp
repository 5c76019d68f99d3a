#include "signals.hpp"

#include <array>
#include <csignal>
#include <cstring>

namespace piezo::host {
namespace {

std::atomic<bool> g_stop_requested{false};
std::atomic<int> g_first_signal{0};
static_assert(std::atomic<bool>::is_always_lock_free, "set from a signal handler");
static_assert(std::atomic<int>::is_always_lock_free, "set from a signal handler");

// Terminating signals a person, a terminal or a session manager sends: each
// asks for the ordinary stop. SIGTSTP (Ctrl-Z) would freeze the process with
// the drive holding its last value, so it stops the run instead.
constexpr std::array kStopping{SIGINT,  SIGTERM, SIGHUP,    SIGQUIT, SIGUSR1, SIGUSR2,
                               SIGTSTP, SIGALRM, SIGVTALRM, SIGPROF, SIGXCPU};
// Signals that only report a failed write or a background terminal access:
// the write fails with EPIPE, EFBIG or EIO instead and the run goes on.
constexpr std::array kIgnored{SIGPIPE, SIGXFSZ, SIGTTIN, SIGTTOU};

std::array<struct sigaction, kStopping.size()> g_previous_stopping{};
std::array<struct sigaction, kIgnored.size()> g_previous_ignored{};

extern "C" void on_stopping_signal(int signal) {
  int none = 0;
  g_first_signal.compare_exchange_strong(none, signal);
  g_stop_requested.store(true);
}

}  // namespace

StopOnSignals::StopOnSignals() {
  g_stop_requested.store(false);
  g_first_signal.store(0);
  struct sigaction stop {};
  stop.sa_handler = on_stopping_signal;
  sigemptyset(&stop.sa_mask);
  for (std::size_t i = 0; i < kStopping.size(); ++i) {
    sigaction(kStopping[i], &stop, &g_previous_stopping[i]);
  }
  struct sigaction ignore {};
  ignore.sa_handler = SIG_IGN;
  sigemptyset(&ignore.sa_mask);
  for (std::size_t i = 0; i < kIgnored.size(); ++i) {
    sigaction(kIgnored[i], &ignore, &g_previous_ignored[i]);
  }
}

StopOnSignals::~StopOnSignals() {
  for (std::size_t i = 0; i < kStopping.size(); ++i) {
    sigaction(kStopping[i], &g_previous_stopping[i], nullptr);
  }
  for (std::size_t i = 0; i < kIgnored.size(); ++i) {
    sigaction(kIgnored[i], &g_previous_ignored[i], nullptr);
  }
}

void StopOnSignals::request_stop() const {
  g_stop_requested.store(true);
}

const std::atomic<bool>& StopOnSignals::flag() const {
  return g_stop_requested;
}

std::string StopOnSignals::received() const {
  const int signal = g_first_signal.load();
  if (signal == 0) return "";
  const char* abbrev = sigabbrev_np(signal);
  return abbrev != nullptr ? std::string("SIG") + abbrev : std::to_string(signal);
}

}  // namespace piezo::host
