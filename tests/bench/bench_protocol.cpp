// Bench: the sample stream's end-to-end latency (board stamp to host
// receipt, p50/p99) and piezod's CPU use at 10 kHz drive + 1 kHz sensor on
// the simulated rig in real time, beside the in-process figures (the same
// loops drained straight from their rings). Board and host share this
// machine's CLOCK_MONOTONIC, so no offset is involved.
// Usage: bench_protocol [seconds]. Figures, not assertions.

#include <fmt/format.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>
#include <zmq_addon.hpp>

#include "../support/rig_sim.hpp"
#include "build_paths.hpp"
#include "config/config_file.hpp"
#include "config/rig.hpp"
#include "piezo/firmware/loop_runner.hpp"
#include "piezo/protocol/frame.hpp"
#include "run/board_client.hpp"

namespace {

using namespace piezo;
using namespace std::chrono_literals;

std::int64_t monotonic_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

struct Latencies {
  std::vector<double> drive_us, sensor_us;
};

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1))];
}

/// utime + stime of a process [s], from /proc.
double cpu_seconds(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(in)), {});
  std::istringstream fields(text.substr(text.rfind(')') + 2));
  std::string f;
  std::vector<std::string> v;
  while (fields >> f) v.push_back(f);
  return (std::stod(v.at(11)) + std::stod(v.at(12))) / static_cast<double>(sysconf(_SC_CLK_TCK));
}

void print_row(const std::string& name, const Latencies& l, const std::string& cpu) {
  fmt::print("{:<28} {:>10.0f} {:>10.0f} {:>10.0f} {:>10.0f} {:>10}  {}\n", name,
             quantile(l.drive_us, 0.5), quantile(l.drive_us, 0.99), quantile(l.sensor_us, 0.5),
             quantile(l.sensor_us, 0.99), l.drive_us.size(), cpu);
}

Latencies over_the_protocol(double seconds, double& cpu_percent) {
  const int port = piezo::testing::free_port(2);
  const std::string address = "tcp://127.0.0.1:" + std::to_string(port);
  piezo::testing::Spawned board(
      {build_paths::piezod, "--config",
       std::string(build_paths::source_dir) + "/configs/piezod-sim.toml", "--listen", address},
      "/dev/null");
  piezo::testing::wait_for_tcp(port);
  host::BoardClient client({address, "", "", 0.0, ""});
  (void)client.call("configure", {{"V0", 80.0}, {"f", 10.0}, {"duration_s", seconds}});
  client.subscribe({"drive", "sensor", "state"});
  std::this_thread::sleep_for(200ms);
  const pid_t pid = board.pid();
  const double cpu_before = cpu_seconds(pid);
  const auto wall_before = std::chrono::steady_clock::now();
  (void)client.call("start");
  Latencies l;
  auto last_lease = std::chrono::steady_clock::now();
  for (bool done = false; !done;) {
    if (!host::poll_in(client.stream(), 10ms)) continue;
    std::vector<zmq::message_t> parts;
    while (zmq::recv_multipart(client.stream(), std::back_inserter(parts),
                               zmq::recv_flags::dontwait)) {
      const std::int64_t now = monotonic_ns();
      const auto topic = parts[0].to_string_view();
      if (topic == "state") {
        done = parts[1].to_string_view().find("summary") != std::string_view::npos;
      } else if (topic == "drive") {
        for (const auto& s : protocol::decode_drive(parts[1].to_string_view()))
          l.drive_us.push_back(1e-3 * static_cast<double>(now - s.t));
      } else {
        for (const auto& s : protocol::decode_sensor(parts[1].to_string_view()))
          l.sensor_us.push_back(1e-3 * static_cast<double>(now - s.t_response));
      }
      parts.clear();
    }
    if (std::chrono::steady_clock::now() - last_lease > 100ms) {
      client.send("lease");
      last_lease = std::chrono::steady_clock::now();
    }
  }
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_before).count();
  cpu_percent = 100.0 * (cpu_seconds(pid) - cpu_before) / wall;
  return l;
}

Latencies in_process(double seconds) {
  auto config =
      config::load_config_file(std::string(build_paths::source_dir) + "/configs/sim.toml");
  config::Rig rig = config::build_rig(config.board);
  const model::Sawtooth waveform(80.0, 10.0, config.host.model.drive.D());
  firmware::WaveformProgram program(waveform);
  std::vector<firmware::RunAxis> axes{{*rig.axes.front().drive, *rig.axes.front().sensor, program,
                                       config.board.axis().drive.limits, 0.1,
                                       config.board.axis().safety}};
  firmware::LoopRunner runner({{config.board.drive_rate_hz, seconds},
                               config.board.sensor_rate_hz,
                               true,
                               config.board.run.priority,
                               config.board.run.lock_memory},
                              std::move(axes), *rig.clock, *rig.lines);
  runner.start([&](hal::TimeNs t0) { rig.start_at(t0); });
  Latencies l;
  // Drained as often as piezod's network thread does (every 2 ms).
  while (!runner.finished()) {
    std::this_thread::sleep_for(2ms);
    const std::int64_t now = monotonic_ns();
    runner.drain(
        0,
        [&](const firmware::DriveSample& s) {
          l.drive_us.push_back(1e-3 * static_cast<double>(now - s.t));
        },
        [&](const firmware::SensorSample& s) {
          l.sensor_us.push_back(1e-3 * static_cast<double>(now - s.t_response));
        });
  }
  runner.join();
  return l;
}

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::stod(argv[1]) : 5.0;
  fmt::print(
      "stream latency, board stamp to host receipt [us], {:g} s at 10 kHz drive + 1 kHz "
      "sensor (simulated rig, real time)\n",
      seconds);
  fmt::print("{:<28} {:>10} {:>10} {:>10} {:>10} {:>10}  {}\n", "path", "drive p50", "drive p99",
             "sensor p50", "sensor p99", "drive n", "piezod CPU");
  double cpu = 0.0;
  const Latencies remote = over_the_protocol(seconds, cpu);
  print_row("piezod over tcp loopback", remote, fmt::format("{:.1f} % of one core", cpu));
  print_row("in-process ring drain", in_process(seconds), "-");
  return 0;
}
