// Bench: displacement samples per second from `piezo rig-sim` over Modbus
// TCP loopback and over RTU on a socat pty pair, beside the wire limit of a
// real RS-485 line at the configured baud. Usage: bench_modbus [seconds].

#include <fmt/format.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "build_paths.hpp"
#include "piezo/hal/modbus/modbus_sensor.hpp"
#include "piezo/hal/posix/monotonic_clock.hpp"

namespace {

using namespace piezo;
using namespace std::chrono_literals;

pid_t spawn(const std::vector<std::string>& argv) {
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    freopen("/dev/null", "w", stdout);
    execv(args[0], args.data());
    _exit(127);
  }
  return pid;
}

void stop(pid_t pid) {
  kill(pid, SIGKILL);
  waitpid(pid, nullptr, 0);
}

struct Result {
  double per_second;
  double mean_ms;
  std::uint64_t errors;
};

Result measure(const hal::modbus::LinkSettings& link, double seconds) {
  hal::posix::MonotonicClock clock;
  hal::modbus::RegisterMap baumer{hal::modbus::Function::input,
                                  202,
                                  hal::modbus::RegisterType::f32,
                                  hal::modbus::WordOrder::CDAB,
                                  1e-3,
                                  0.0,
                                  1};
  hal::modbus::ModbusSensor sensor(link, baumer, clock);
  const auto end = clock.now() + hal::from_seconds(seconds);
  std::uint64_t n = 0, errors = 0;
  double latency = 0;
  while (clock.now() < end) {
    const auto r = sensor.read();
    ++n;
    errors += r.status == hal::Status::ok ? 0 : 1;
    latency += hal::to_seconds(r.t_response - r.t_request);
  }
  return {static_cast<double>(n) / seconds, 1e3 * latency / static_cast<double>(n), errors};
}

/// Transactions per second an RTU line allows for one FC04 read of `words`
/// registers: request 8 bytes, reply 5 + 2 words, 11-bit characters, a
/// 3.5-character silence after each frame.
double rtu_wire_limit(int baud, int words, int bits_per_char) {
  const double chars = 8 + (5 + 2 * words) + 2 * 3.5;
  return baud / (chars * bits_per_char);
}

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::stod(argv[1]) : 3.0;
  const std::string piezo = build_paths::piezo,
                    config = std::string(build_paths::source_dir) + "/configs/modbus-hil.toml";
  const auto dir =
      std::filesystem::temp_directory_path() / ("piezo-bench-" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);

  const int port = 15000 + getpid() % 5000;
  const pid_t tcp_sim =
      spawn({piezo, "rig-sim", "--config", config, "--tcp", "127.0.0.1:" + std::to_string(port)});
  std::this_thread::sleep_for(500ms);
  hal::modbus::LinkSettings tcp;
  tcp.port = port;
  const Result t = measure(tcp, seconds);
  stop(tcp_sim);

  const std::string a = (dir / "ptyA").string(), b = (dir / "ptyB").string();
  const pid_t socat =
      spawn({"/usr/bin/socat", "pty,raw,echo=0,link=" + a, "pty,raw,echo=0,link=" + b});
  std::this_thread::sleep_for(300ms);
  const pid_t rtu_sim = spawn({piezo, "rig-sim", "--config", config, "--rtu", a});
  std::this_thread::sleep_for(500ms);
  hal::modbus::LinkSettings rtu;
  rtu.transport = hal::modbus::LinkSettings::Transport::rtu;
  rtu.device = b;
  const Result r = measure(rtu, seconds);
  stop(rtu_sim);
  stop(socat);
  std::filesystem::remove_all(dir);

  fmt::print("Baumer OM30 read (FC04, 2 registers), {} s each\n", seconds);
  fmt::print("{:<38} {:>12} {:>12} {:>8}\n", "", "samples/s", "mean [ms]", "errors");
  fmt::print("{:<38} {:>12.0f} {:>12.3f} {:>8}\n", "Modbus TCP, loopback", t.per_second, t.mean_ms,
             t.errors);
  fmt::print("{:<38} {:>12.0f} {:>12.3f} {:>8}\n", "Modbus RTU, pty pair (no baud pacing)",
             r.per_second, r.mean_ms, r.errors);
  for (const int baud : {19200, 57600, 115200}) {
    fmt::print("{:<38} {:>12.0f}   (8E1: 11-bit characters, 3.5-character gaps)\n",
               fmt::format("RTU wire limit at {} baud", baud), rtu_wire_limit(baud, 2, 11));
  }
  return 0;
}
