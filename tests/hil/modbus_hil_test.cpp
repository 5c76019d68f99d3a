// The real Modbus backends across real links: `piezo rig-sim` over TCP and
// over RTU on a socat pty pair, read by our client and by mbpoll; a pymodbus
// server posing as a sensor, read by our client; and faults injected by
// rig-sim or by killing it.

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <thread>

#include "../support/rig_sim.hpp"
#include "build_paths.hpp"

namespace piezo::testing {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

const std::string kPymodbusSensor =
    std::string(build_paths::source_dir) + "/tests/hil/pymodbus_sensor.py";

TEST_F(ModbusHil, OurClientReadsRigSimOverTcp) {
  auto rig = start_rig_sim();
  ASSERT_TRUE(wait_for_tcp(port));
  const auto j = sensor_read(20, tcp_sets());
  EXPECT_EQ(j.at("errors"), 0);
  ASSERT_EQ(j.at("readings").size(), 20u);
  for (const auto& r : j.at("readings")) {
    EXPECT_EQ(r.at("status"), "ok");
    EXPECT_NEAR(r.at("displacement_m").get<double>(), 0.07, 5e-6);  // target distance, at rest
  }
}

TEST_F(ModbusHil, MbpollReadsRigSimsBaumerRegisters) {
  auto rig = start_rig_sim();
  ASSERT_TRUE(wait_for_tcp(port));
  // mbpoll numbers registers from 1; its default float word order is CDAB.
  const auto r = run_command("mbpoll -m tcp -a 1 -t 3:float -r 203 -c 1 -1 -p " +
                             std::to_string(port) + " 127.0.0.1");
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const auto at = r.out.find("[203]:");
  ASSERT_NE(at, std::string::npos) << r.out;
  EXPECT_NEAR(std::stod(r.out.substr(at + 6)), 70.0, 0.01) << r.out;
}

TEST_F(ModbusHil, SeveralClientsAtOnce) {
  auto rig = start_rig_sim();
  ASSERT_TRUE(wait_for_tcp(port));
  std::vector<std::thread> clients;
  std::vector<int> errors(3, -1);
  for (int i = 0; i < 3; ++i) {
    clients.emplace_back([&, i] {
      const auto r = run_command(kPiezo + " sensor read --config " + kConfig +
                                 " --count 50 --json " + tcp_sets());
      if (r.exit_code == 0)
        errors[static_cast<std::size_t>(i)] = nlohmann::json::parse(r.out)["errors"];
    });
  }
  for (auto& c : clients) c.join();
  EXPECT_EQ(errors, (std::vector<int>{0, 0, 0}));
}

TEST_F(ModbusHil, PymodbusSensorOverTcpIsDecodedRight) {
  Spawned sensor({"/usr/bin/python3", kPymodbusSensor, "tcp", std::to_string(port)},
                 (dir / "pymodbus.txt").string());
  ASSERT_TRUE(wait_for_tcp(port));
  const auto j = sensor_read(3, tcp_sets() + " --set sensor.modbus.preset=baumer-om30");
  for (const auto& r : j.at("readings")) {
    EXPECT_NEAR(r.at("displacement_m").get<double>(), 0.0697426, 1e-7) << j.dump();
  }
}

TEST_F(ModbusRtu, OurClientReadsRigSimOverRtu) {
  auto rig = start_rig_sim({"--rtu", (dir / "ptyA").string()});
  ASSERT_TRUE(wait_for_peer(rtu_sets()));
  const auto j = sensor_read(10, rtu_sets());
  EXPECT_EQ(j.at("errors"), 0) << j.dump();
  for (const auto& r : j.at("readings")) {
    EXPECT_NEAR(r.at("displacement_m").get<double>(), 0.07, 5e-6);
  }
}

// Two sensors on one RTU line (one pty, each at its own registers) share
// the board's one connection to it, read in turn each acquire tick; the
// outputs go over TCP to the same rig-sim. A group move ends on target on
// both; a second sensor that asks the line at another baud is refused.
TEST_F(ModbusRtu, TwoSensorsShareOneRtuLine) {
  const std::string config = std::string(build_paths::source_dir) + "/configs/two-axes-modbus.toml";
  Spawned rig({kPiezo, "rig-sim", "--config", config, "--tcp", "127.0.0.1:" + std::to_string(port),
               "--rtu", (dir / "ptyA").string()},
              (dir / "rig-sim.txt").string());
  ASSERT_TRUE(wait_for_tcp(port));
  // 57600 baud: a read takes some 4 ms each way; a loaded machine may add
  // tens of ms, so the timeouts are wider than the configured 50 ms.
  const std::string sets =
      " --set drive.modbus-ao.port=" + std::to_string(port) +
      " --set sensor.backend=modbus-rtu --set sensor.modbus.device=" + (dir / "ptyB").string() +
      " --set sensor.rate_hz=100 --set sensor.modbus.response_timeout_s=0.2"
      " --set safety.sensor_stale_s=0.5";
  // What is checked is the shared line, not the controller's finish: a
  // tolerance and a time that a sanitizer build on a loaded machine meets.
  const auto r = run_command(kPiezo + " move --config " + config + sets +
                             " --to theta=0.002 --to phi=-0.003 --tolerance 2e-4 --timeout 60"
                             " --json --out " +
                             (dir / "group").string());
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  const auto j = nlohmann::json::parse(r.out);
  for (const auto& m : j.at("moves")) EXPECT_EQ(m.at("stop_cause"), "on_target") << m.dump();

  const auto other_baud = run_command(
      kPiezo + " move --config " + config + sets + " --set axes.phi.sensor.modbus.baud=19200" +
      " --to theta=0.001 --to phi=-0.001 --out " + (dir / "refused").string());
  EXPECT_NE(other_baud.exit_code, 0);
  EXPECT_NE(other_baud.err.find("one line has one set of settings"), std::string::npos)
      << other_baud.err;
}

TEST_F(ModbusRtu, PymodbusSensorOverRtuIsDecodedRight) {
  // pyserial cannot set parity on a pseudo-terminal twice (EINVAL): 8N1 here.
  Spawned sensor({"/usr/bin/python3", kPymodbusSensor, "rtu", (dir / "ptyA").string(), "N"},
                 (dir / "pymodbus.txt").string());
  const std::string sets = rtu_sets("N") + " --set sensor.modbus.preset=baumer-om30" +
                           " --set sensor.modbus.response_timeout_s=0.5";
  ASSERT_TRUE(wait_for_peer(sets)) << read_all(dir / "pymodbus.txt");
  const auto j = sensor_read(3, sets);
  EXPECT_EQ(j.at("errors"), 0) << j.dump();
  for (const auto& r : j.at("readings")) {
    EXPECT_NEAR(r.at("displacement_m").get<double>(), 0.0697426, 1e-7) << j.dump();
  }
}

// A line rig-sim cannot open is refused by name, and nothing is left
// behind (a sanitizer build's leak check would change the exit code).
TEST_F(ModbusRtu, ALineRigSimCannotOpenIsRefusedByName) {
  const std::string missing = (dir / "no-such-pty").string();
  const auto r =
      run_command(kPiezo + " rig-sim --config " + kConfig +
                  " --set sensor.modbus.port=" + std::to_string(port) + " --rtu " + missing);
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("cannot open " + missing), std::string::npos) << r.err;
}

TEST_F(ModbusHil, RunCompletesAgainstRigSim) {
  auto rig = start_rig_sim();
  ASSERT_TRUE(wait_for_tcp(port));
  const auto r = run_command(kPiezo + " run --config " + kConfig + " --duration 1 --json " +
                             tcp_sets() + " --set drive.modbus-ao.port=" + std::to_string(port) +
                             " --out " + (dir / "run").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("status"), "completed");
  // Every 1 kHz deadline in 1 s was either served or counted as missed.
  EXPECT_GE(j.at("drive").at("samples").get<int>() + j.at("drive").at("missed_cycles").get<int>(),
            1000);
  EXPECT_EQ(j.at("drive").at("errors").get<int>(), 0);
  EXPECT_GE(j.at("sensor").at("samples").get<int>() + j.at("sensor").at("missed_cycles").get<int>(),
            200);
  EXPECT_EQ(j.at("sensor").at("errors").get<int>(), 0);
  EXPECT_GT(j.at("theta_end_rad").get<double>(), 1e-3) << "the drive moved rig-sim's plant";
}

// Two axes on one simulated Modbus device (configs/two-axes-modbus.toml):
// one group move through the real backends over TCP, each axis's output on
// its own holding register and its rotor read by mbpoll from its own
// sensor registers; a config whose axes share a register is refused.
TEST_F(ModbusHil, AGroupMoveOfTwoAxesOverModbus) {
  const std::string config = std::string(build_paths::source_dir) + "/configs/two-axes-modbus.toml";
  const std::string at_port = " --set sensor.modbus.port=" + std::to_string(port) +
                              " --set drive.modbus-ao.port=" + std::to_string(port);
  Spawned rig({kPiezo, "rig-sim", "--config", config, "--set",
               "sensor.modbus.port=" + std::to_string(port)},
              (dir / "rig-sim.txt").string());
  ASSERT_TRUE(wait_for_tcp(port));
  const auto r =
      run_command(kPiezo + " move --config " + config + at_port +
                  " --to theta=0.002 --to phi=-0.003 --json --out " + (dir / "group").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j.at("moves").size(), 2u);
  // The device's own registers (mbpoll, 0-based): each laser reads its own
  // rotor [mm], 70 mm at zero, r2 = 62 mm.
  const auto laser_mm = [&](int address) {
    const auto read = run_command("mbpoll -m tcp -0 -a 1 -t 3:float -r " + std::to_string(address) +
                                  " -c 1 -1 -p " + std::to_string(port) + " 127.0.0.1");
    const auto at = read.out.find("[" + std::to_string(address) + "]:");
    return at == std::string::npos ? NAN : std::stod(read.out.substr(at + 6));
  };
  for (const auto& m : j.at("moves")) EXPECT_TRUE(m.at("on_target").get<bool>()) << m.dump();
  EXPECT_NEAR(laser_mm(202), 70.0 + 62.0 * 0.002, 0.01);
  EXPECT_NEAR(laser_mm(212), 70.0 - 62.0 * 0.003, 0.01);
  EXPECT_EQ(read_ao_register(), 0) << "theta's output left at 0 V";

  const auto shared = run_command(
      kPiezo + " rig-sim --config " + config +
      " --set axes.phi.drive.modbus-ao.address=0 --tcp 127.0.0.1:" + std::to_string(free_port()));
  EXPECT_EQ(shared.exit_code, 2);
  EXPECT_NE(shared.err.find("axes.phi.drive.modbus-ao.address: holding register 0 is also "
                            "axes.theta.drive.modbus-ao.address's"),
            std::string::npos)
      << shared.err;
}

// The link comes back by itself: reads fail as `disconnected` while rig-sim is
// away, and succeed again once it returns. A read that had waited on the dead
// link would be classed `timeout`; the class, not a stopwatch, shows it did not
// (how fast the failure comes is a benchmark's question, not a test's).
TEST_F(ModbusHil, TheLinkReconnectsAfterTheServerReturns) {
  auto rig = start_rig_sim();
  ASSERT_TRUE(wait_for_tcp(port));
  CommandResult result;
  std::thread reader([&] {
    result = run_command(kPiezo + " sensor read --config " + kConfig + " --count 600 --json " +
                         tcp_sets());  // 3 s at 200 Hz
  });
  EXPECT_TRUE(poll_until([&] { return has_a_client(port); }, 60000ms, 20ms));
  std::this_thread::sleep_for(300ms);  // reads that succeed before the loss
  rig->signal(SIGKILL);
  rig->wait_exit();
  std::this_thread::sleep_for(500ms);
  rig = start_rig_sim();
  reader.join();
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const auto j = nlohmann::json::parse(result.out);
  const auto& readings = j.at("readings");
  int disconnected = 0;
  int timed_out = 0;
  for (const auto& r : readings) {
    if (r.at("status") == "disconnected") ++disconnected;
    if (r.at("status") == "timeout") ++timed_out;
  }
  EXPECT_GT(disconnected, 10);
  // The read in flight when rig-sim dies may time out; later ones must not.
  EXPECT_LE(timed_out, 1) << "reads waited on a dead link";
  EXPECT_EQ(readings.back().at("status"), "ok") << "reconnected before the end";
}

TEST_F(ModbusHil, ExceptionRepliesAreCountedAsSuch) {
  auto rig = start_rig_sim({"--set", "rig_sim.exception_probability=1"});
  ASSERT_TRUE(wait_for_tcp(port));
  const auto j = sensor_read(5, tcp_sets(), 1);
  EXPECT_EQ(j.at("errors"), 5);
  for (const auto& r : j.at("readings")) EXPECT_EQ(r.at("status"), "exception_reply");
}

/// Readings of a sensor that answers late or never: the first, on a fresh
/// connection, times out; after a timeout the link reconnects before the
/// next request, which waits up to one response timeout for it (docs/
/// hardware.md) and is `disconnected` if a loaded machine takes longer.
/// None may pass for a good reading.
void expect_timeouts(const nlohmann::json& j) {
  const auto& readings = j.at("readings");
  ASSERT_EQ(readings.size(), 3u) << j.dump();
  EXPECT_EQ(readings.front().at("status"), "timeout") << j.dump();
  for (const auto& r : readings) {
    EXPECT_TRUE(r.at("status") == "timeout" || r.at("status") == "disconnected") << j.dump();
  }
}

TEST_F(ModbusHil, SlowRepliesTimeOut) {
  auto rig = start_rig_sim({"--set", "rig_sim.response_delay_s=0.2"});
  ASSERT_TRUE(wait_for_tcp(port));
  const auto j = sensor_read(3, tcp_sets() + " --set sensor.modbus.response_timeout_s=0.05", 1);
  expect_timeouts(j);
}

TEST_F(ModbusHil, DroppedRepliesTimeOut) {
  auto rig = start_rig_sim({"--set", "rig_sim.drop_probability=1"});
  ASSERT_TRUE(wait_for_tcp(port));
  const auto j = sensor_read(3, tcp_sets(), 1);
  expect_timeouts(j);
}

/// A run whose rig-sim dies: the stop gives up writing 0 V after
/// safety.stop_confirm_s, the log is closed and marked failed with the
/// output unconfirmed, and the process exits non-zero instead of hanging.
void expect_run_fails_safely(ModbusHil& t, const fs::path& dir, int port,
                             const std::function<void()>& break_link) {
  const auto out = dir / "run";
  Spawned run({kPiezo, "run", "--config", kConfig, "--duration", "30", "--set",
               "sensor.modbus.port=" + std::to_string(port), "--set",
               "drive.modbus-ao.port=" + std::to_string(port), "--json", "--out", out.string()},
              (dir / "run.txt").string());
  break_link();
  const auto broken = std::chrono::steady_clock::now();
  EXPECT_EQ(run.wait_exit(), 1);
  const double took =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - broken).count();
  // A bound on hanging, not a speed goal: the stop gives up after
  // safety.stop_confirm_s (1 s here); a loaded CI machine may add seconds.
  EXPECT_LT(took, 15.0);
  // Nothing can reach a dead module: the log must not claim a 0 V it never
  // reached. Its last record holds what the module last acknowledged,
  // marked unconfirmed (which may itself be 0 V when the link died at a
  // period's start: the sawtooth is at 0 there).
  const auto check = run_command("/usr/bin/python3 -c \"import h5py, json; f = h5py.File('" +
                                 (out / "run.h5").string() +
                                 "', 'r'); o = json.loads(f.attrs['summary'])['output']; "
                                 "print(f.attrs['status'].decode(), f.attrs['output'].decode(), "
                                 "float(f['axes/rotor/drive/phase'][-1]), "
                                 "f['axes/rotor/drive/V'][-1] == o['last_acknowledged_V'], "
                                 "o['last_acknowledged_V'] is not None)\"");
  EXPECT_EQ(check.out, "failed output_unconfirmed 3.0 True True\n") << check.err;
  (void)t;
}

TEST_F(ModbusHil, AKilledRigSimEndsTheRunSafely) {
  auto rig = start_rig_sim();
  ASSERT_TRUE(wait_for_tcp(port));
  expect_run_fails_safely(*this, dir, port, [&] {
    ASSERT_TRUE(wait_for_drive());
    rig->signal(SIGKILL);
  });
}

TEST_F(ModbusHil, ADisconnectEndsTheRunSafely) {
  // rig-sim drops every client 0.5 s into the drive and lets nobody back in.
  auto rig = start_rig_sim(
      {"--set", "rig_sim.disconnect_at_s=0.5", "--set", "rig_sim.times_from_drive=true"});
  ASSERT_TRUE(wait_for_tcp(port));
  expect_run_fails_safely(*this, dir, port, [] {});
}

}  // namespace
}  // namespace piezo::testing
