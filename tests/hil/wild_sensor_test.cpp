// A sensor that reads wild: a Modbus peer (pymodbus) answering a wrong word
// order, spikes, NaN and random words, with rig-sim as the drive. The host
// never hangs on it: readings outside the measuring range are out_of_range
// (counted, logged, never an angle), the observer gates what is left, and
// SIGINT ends a run within its ramp. `piezo sensor read` names the word
// order that would read right.

#include <gtest/gtest.h>

#include <chrono>
#include <csignal>
#include <iostream>
#include <nlohmann/json.hpp>
#include <thread>

#include "../support/rig_sim.hpp"
#include "build_paths.hpp"

namespace piezo::testing {
namespace {

using namespace std::chrono_literals;

const std::string kWildSensor = std::string(build_paths::source_dir) + "/tests/hil/wild_sensor.py";

class WildSensor : public ModbusHil {
 protected:
  int sensor_port = free_port();
  std::unique_ptr<Spawned> rig, sensor;

  void start(const std::string& mode) {
    rig = start_rig_sim();
    sensor = std::make_unique<Spawned>(std::vector<std::string>{"/usr/bin/python3", kWildSensor,
                                                                mode, std::to_string(sensor_port)},
                                       (dir / "sensor.txt").string());
    ASSERT_TRUE(wait_for_tcp(port));
    ASSERT_TRUE(wait_for_tcp(sensor_port));
  }
  /// The drive on rig-sim, the sensor on the wild peer.
  [[nodiscard]] std::string sets() const {
    return "--set drive.modbus-ao.port=" + std::to_string(port) +
           " --set sensor.modbus.port=" + std::to_string(sensor_port);
  }
  /// `piezo run` bounded by `timeout` (a hang is a failure, not a stuck suite).
  nlohmann::json run(const std::string& extra, int expected_exit) {
    const auto r = run_command("timeout -s KILL 120 " + kPiezo + " run --config " + kConfig +
                               " --duration 2 --json " + sets() + " " + extra + " --out " +
                               (dir / "run").string());
    EXPECT_EQ(r.exit_code, expected_exit) << r.err;
    return r.out.empty() ? nlohmann::json{} : nlohmann::json::parse(r.out);
  }
  /// Statuses of the logged sensor samples, and the observer's rows, by h5py.
  std::string logged() const {
    return run_command("/usr/bin/python3 -c \"import h5py, numpy as np; f = h5py.File('" +
                       (dir / "run" / "run.h5").string() +
                       "'); s = f['axes/rotor/sensor/status'][:]; o = "
                       "f['axes/rotor/observer/theta_hat'][:]; "
                       "print(int(np.sum(s == 7)), int(np.sum(s == 2)), len(o), "
                       "bool(np.all(np.isfinite(o))), float(np.max(np.abs(o))) if len(o) else 0)\"")
        .out;
  }
};

// The word-order mistake any user can make, on rig-sim's moving rotor: most
// readings are 1e30 m and more, and those that fall inside the range jump
// about. The readings are out_of_range, the board's sensor check stops the
// run, and the observer is never thrown (it once crawled for good on them).
TEST_F(WildSensor, AWrongWordOrderIsOutOfRangeAndEndsTheRun) {
  start("steady");
  const auto r =
      run_command("timeout -s KILL 120 " + kPiezo + " run --config " + kConfig +
                  " --duration 2 --json --set sensor.modbus.word_order=ABCD --set "
                  "drive.modbus-ao.port=" +
                  std::to_string(port) + " --set sensor.modbus.port=" + std::to_string(port) +
                  " --out " + (dir / "run").string());
  ASSERT_EQ(r.exit_code, 1) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.value("stop_cause", ""), "sensor_fault") << j.dump();
  EXPECT_EQ(j.at("output").at("state"), "confirmed") << j.dump();
  std::istringstream in(logged());
  long out_of_range = 0, invalid = 0, observer_rows = -1;
  std::string finite;
  double largest = 1e300;
  in >> out_of_range >> invalid >> observer_rows >> finite >> largest;
  EXPECT_GT(out_of_range, 10);
  EXPECT_EQ(finite, "True");
  EXPECT_LT(largest, 10.0);
  // The user's first tool says what is wrong (the peer holds 69.7426 mm).
  const auto read = run_command(kPiezo + " sensor read --config " + kConfig +
                                " --count 3 --json --set sensor.modbus.word_order=ABCD --set "
                                "sensor.modbus.port=" +
                                std::to_string(sensor_port));
  EXPECT_NE(read.err.find("word_order = ABCD"), std::string::npos) << read.err;
  EXPECT_NE(read.err.find("in CDAB they read 0.0697426 m"), std::string::npos) << read.err;
}

// Spikes of 5 mm (0.08 rad) and NaN readings in a steady stream: NaN is
// invalid_reading, the spikes are gated by the observer, which stays on the
// rotor (never restarted, never near a spike), and the run completes.
TEST_F(WildSensor, SpikesAreGatedAndNaNIsInvalid) {
  for (const std::string mode : {"spike", "nan"}) {
    SCOPED_TRACE(mode);
    start(mode);
    fs::remove_all(dir / "run");
    // A low drive: the observer's model then expects the (steady) rotor to
    // creep, not to step, so only the spikes are outliers.
    const auto j = run("--set drive.V0=20", 0);
    EXPECT_EQ(j.value("status", ""), "completed") << j.dump();
    const auto& observer = j.at("observer");
    if (mode == "spike") {
      EXPECT_GT(observer.at("outliers").get<int>(), 0) << j.dump();
      EXPECT_EQ(observer.at("restarts").get<int>(), 0) << j.dump();
    }
    std::istringstream in(logged());
    long out_of_range = 0, invalid = 0, rows = 0;
    std::string finite;
    double largest = 0;
    in >> out_of_range >> invalid >> rows >> finite >> largest;
    EXPECT_EQ(finite, "True");
    EXPECT_LT(largest, 0.05) << "the observer followed a spike";
    if (mode == "nan") {
      EXPECT_GT(invalid, 0);
    }
    rig.reset();
    sensor.reset();
  }
}

// Readings no rotor gives (3.4e35 m, -1000 m, a 1e6 mm spike) among steady
// ones: each is out_of_range, never an angle, and the run completes in
// about its own time (a 1e6 mm spike once cost 8.5 s of wall time on a
// 1.5 s run; the wall time is printed, not asserted).
TEST_F(WildSensor, ReadingsNoRotorGivesAreOutOfRange) {
  start("huge");
  const auto started = std::chrono::steady_clock::now();
  const auto j = run("--set drive.V0=20", 0);
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  std::cout << "2 s run with wild readings: " << wall_s << " s of wall time\n";
  EXPECT_EQ(j.value("status", ""), "completed") << j.dump();
  std::istringstream in(logged());
  long out_of_range = 0, invalid = 0, rows = 0;
  std::string finite;
  double largest = 1e300;
  in >> out_of_range >> invalid >> rows >> finite >> largest;
  EXPECT_GE(out_of_range, 3) << "each kind at least once";
  EXPECT_GT(rows, 100);
  EXPECT_EQ(finite, "True");
  EXPECT_LT(largest, 0.05) << "the observer followed a wild reading";
}

// Random words: whatever they read as, the host keeps up, and SIGINT ends
// the run (a hang in the observer once ignored it for 27 minutes).
TEST_F(WildSensor, GarbageNeverHangsTheHostAndSigintEndsTheRun) {
  start("garbage");
  Spawned host({kPiezo, "run", "--config", kConfig, "--duration", "60", "--json", "--set",
                "drive.modbus-ao.port=" + std::to_string(port), "--set",
                "sensor.modbus.port=" + std::to_string(sensor_port), "--set",
                "safety.max_sensor_errors=1000000", "--out", (dir / "run").string()},
               (dir / "host.txt").string());
  ASSERT_TRUE(wait_for_drive());
  std::this_thread::sleep_for(1s);
  host.signal(SIGINT);
  // Generous for a loaded machine; the hang this guards against was endless.
  const bool ended = poll_until([&] { return host.exited(); }, 30000ms, 50ms);
  ASSERT_TRUE(ended) << "piezo run did not answer SIGINT";
  std::istringstream in(logged());
  long out_of_range = 0, invalid = 0, rows = 0;
  std::string finite;
  in >> out_of_range >> invalid >> rows >> finite;
  EXPECT_GT(out_of_range, 0);
  EXPECT_EQ(finite, "True");
}

}  // namespace
}  // namespace piezo::testing
