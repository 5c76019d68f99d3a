#pragma once
// `piezo rig-sim` for tests over real links: a free loopback port, waiting
// for the server or a pty, and a fixture that starts rig-sim with the
// Modbus HIL config and reads it with the independent peers.

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "build_paths.hpp"
#include "run_command.hpp"
#include "spawn.hpp"

namespace piezo::testing {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

inline const std::string kPiezo = build_paths::piezo;
inline const std::string kConfig =
    std::string(build_paths::source_dir) + "/configs/modbus-hil.toml";

/// True when nothing on this machine holds `port` on loopback.
inline bool port_is_free(int port) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const bool free = bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
  close(fd);
  return free;
}

/// A port P with P .. P + count - 1 free (piezod takes two: commands on P,
/// its stream on P + 1). Chosen below the kernel's ephemeral range: the
/// outgoing connections of the other tests on a busy machine take their
/// local ports from that range and can take one between this check and the
/// listener's bind; below it only another listener can, on the same random
/// port.
inline int free_port(int count = 1) {
  int ephemeral_start = 32768;
  if (std::ifstream range("/proc/sys/net/ipv4/ip_local_port_range"); range) {
    range >> ephemeral_start;
  }
  static std::mt19937 pick{std::random_device{}()};
  std::uniform_int_distribution<int> below(10000, ephemeral_start - count - 1);
  for (;;) {
    const int port = below(pick);
    bool free = true;
    for (int i = 0; i < count && free; ++i) free = port_is_free(port + i);
    if (free) return port;
  }
}

/// Asks `ready` every `interval` until it says yes (true) or `timeout` passes (false).
template <class Ready>
bool poll_until(Ready&& ready, std::chrono::milliseconds timeout,
                std::chrono::milliseconds interval = 50ms) {
  const auto until = std::chrono::steady_clock::now() + timeout;
  while (!ready()) {
    if (std::chrono::steady_clock::now() >= until) return false;
    std::this_thread::sleep_for(interval);
  }
  return true;
}

inline bool wait_for_tcp(int port) {
  return poll_until(
      [port] {
        const int fd = socket(AF_INET, SOCK_STREAM, 0);
        sockaddr_in addr{};
        addr.sin_family = AF_INET;
        addr.sin_port = htons(static_cast<std::uint16_t>(port));
        addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        const bool ok = connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
        close(fd);
        return ok;
      },
      5000ms);
}

/// True once a client holds a connection to `port` on loopback (IPv4), as
/// the kernel's table says: a client slow to start (a sanitized build on a
/// loaded machine takes seconds) has not connected after any fixed sleep.
inline bool has_a_client(int port) {
  std::ifstream table("/proc/net/tcp");
  std::string line;
  std::getline(table, line);  // the header
  char local[64] = {};
  char state[8] = {};
  while (std::getline(table, line)) {
    if (std::sscanf(line.c_str(), "%*d: %63s %*s %7s", local, state) != 2) continue;
    const char* colon = std::strchr(local, ':');
    if (colon != nullptr && std::strtol(colon + 1, nullptr, 16) == port &&
        std::string(state) == "01") {  // TCP_ESTABLISHED
      return true;
    }
  }
  return false;
}

inline bool wait_for_path(const fs::path& p) {
  return poll_until([&p] { return fs::exists(p); }, 5000ms);
}

class ModbusHil : public ::testing::Test {
 protected:
  fs::path dir = fresh_temp_dir(::testing::UnitTest::GetInstance()->current_test_info()->name());
  int port = free_port();

  std::unique_ptr<Spawned> start_rig_sim(const std::vector<std::string>& extra = {}) {
    std::vector<std::string> args{kPiezo,  "rig-sim", "--config",
                                  kConfig, "--set",   "sensor.modbus.port=" + std::to_string(port)};
    args.insert(args.end(), extra.begin(), extra.end());
    auto rig = std::make_unique<Spawned>(args, (dir / "rig-sim.txt").string());
    return rig;
  }

  /// `piezo sensor read --json` against the port (or the given --set keys).
  nlohmann::json sensor_read(int count, const std::string& sets, int expected_exit = 0) {
    const auto r = run_command(kPiezo + " sensor read --config " + kConfig + " --count " +
                               std::to_string(count) + " --json " + sets);
    EXPECT_EQ(r.exit_code, expected_exit) << r.err;
    return r.out.empty() ? nlohmann::json{} : nlohmann::json::parse(r.out);
  }

  std::string tcp_sets() const { return "--set sensor.modbus.port=" + std::to_string(port); }

  /// rig-sim's analog-output holding register (address 0), read by mbpoll
  /// (an independent peer); -1 when it cannot be read.
  [[nodiscard]] int read_ao_register() const {
    const auto r = run_command("mbpoll -m tcp -a 1 -t 4 -r 1 -c 1 -1 -p " + std::to_string(port) +
                               " 127.0.0.1");
    const auto at = r.out.find("[1]:");
    if (r.exit_code != 0 || at == std::string::npos) return -1;
    return std::stoi(r.out.substr(at + 4));
  }

  /// Waits (at most 60 s) until a run drives rig-sim's output above 0 V: a
  /// fault meant for the middle of a run must not come before its start,
  /// however long a loaded machine takes to get there.
  [[nodiscard]] bool wait_for_drive() const {
    return poll_until([this] { return read_ao_register() > 0; }, 60000ms, 20ms);
  }
};

class ModbusRtu : public ModbusHil {
 protected:
  void SetUp() override {
    pty_pair = std::make_unique<Spawned>(
        std::vector<std::string>{"/usr/bin/socat", "pty,raw,echo=0,link=" + (dir / "ptyA").string(),
                                 "pty,raw,echo=0,link=" + (dir / "ptyB").string()},
        (dir / "socat.txt").string());
    ASSERT_TRUE(wait_for_path(dir / "ptyA") && wait_for_path(dir / "ptyB"));
  }
  std::string rtu_sets(const std::string& parity = "E") const {
    return "--set sensor.backend=modbus-rtu --set sensor.modbus.device=" + (dir / "ptyB").string() +
           " --set sensor.modbus.parity=" + parity;
  }
  /// Waits until a peer on the pty's other end answers a read (a server
  /// that starts slowly on a loaded machine: pymodbus takes seconds).
  [[nodiscard]] bool wait_for_peer(const std::string& sets) const {
    return poll_until(
        [&] {
          return run_command(kPiezo + " sensor read --config " + kConfig + " --count 1 " + sets)
                     .exit_code == 0;
        },
        60s, 100ms);
  }
  std::unique_ptr<Spawned> pty_pair;
};

}  // namespace piezo::testing
