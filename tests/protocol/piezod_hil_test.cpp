// piezod as its own process on loopback, with real clients: `piezo run
// --rig`, an independent Python client written from docs/protocol.md, a
// host killed with -9 (the board stops itself), and CURVE.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <regex>
#include <sstream>

#include "build_paths.hpp"
#include "rig_sim.hpp"

namespace piezo::testing {
namespace {

const std::string kPiezod = build_paths::piezod;
const std::string kSource = build_paths::source_dir;
const std::string kSimConfig = kSource + "/configs/sim.toml";

/// piezod on the simulated rig, on a free loopback port, with extra
/// [piezod]/[run] lines.
class Piezod : public ::testing::Test {
 protected:
  void start(const std::string& extra_toml = "", const std::vector<std::string>& extra_args = {}) {
    dir_ = fresh_temp_dir("piezod");
    port_ = free_port(2);
    address_ = "tcp://127.0.0.1:" + std::to_string(port_);
    // Extra [piezod] keys go right under the section's header, in place of
    // the file's own lines for the same keys.
    std::string board = read_all(kSource + "/configs/piezod-sim.toml");
    std::istringstream extra_lines(extra_toml);
    for (std::string line; std::getline(extra_lines, line);) {
      const std::string key = line.substr(0, line.find(' '));
      const auto at = board.find("\n" + key + " ");
      if (at != std::string::npos) board.erase(at + 1, board.find('\n', at + 1) - at);
    }
    board.insert(board.find("[piezod]\n") + 9, extra_toml);
    write_file(dir_ / "board.toml", board);
    std::vector<std::string> argv{kPiezod, "--config", (dir_ / "board.toml").string(), "--listen",
                                  address_};
    argv.insert(argv.end(), extra_args.begin(), extra_args.end());
    daemon_ = std::make_unique<Spawned>(argv, (dir_ / "piezod.log").string());
    ASSERT_TRUE(wait_for_tcp(port_)) << read_all(dir_ / "piezod.log");
  }
  [[nodiscard]] std::string log() const { return read_all(dir_ / "piezod.log"); }
  nlohmann::json status() {
    const auto r = run_command(kPiezo + " status --json --rig " + address_);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return nlohmann::json::parse(r.out);
  }

  fs::path dir_;
  int port_ = 0;
  std::string address_;
  std::unique_ptr<Spawned> daemon_;
};

TEST_F(Piezod, RunOverTheProtocolMatchesTheInProcessRun) {
  // Both on the virtual clock: the same samples whatever else the machine
  // does (in real time, a loaded machine's missed cycles change the angle).
  start("", {"--set", "run.clock=virtual"});
  const auto remote = run_command(kPiezo + " run --config " + kSimConfig + " --rig " + address_ +
                                  " --json --out " + (dir_ / "remote").string());
  ASSERT_EQ(remote.exit_code, 0) << remote.err;
  const auto local =
      run_command(kPiezo + " run --config " + kSimConfig +
                  " --set run.clock=virtual --json --out " + (dir_ / "local").string());
  ASSERT_EQ(local.exit_code, 0) << local.err;
  const auto r = nlohmann::json::parse(remote.out), l = nlohmann::json::parse(local.out);
  EXPECT_EQ(r.at("status"), "completed");
  EXPECT_EQ(r.at("output").at("state"), "confirmed");
  // Same plant, same waveform, same clock: the angles agree.
  const double theta_r = r.at("theta_end_rad"), theta_l = l.at("theta_end_rad");
  EXPECT_NEAR(theta_r, theta_l, 0.05 * theta_l);
  // h5py reads the host's log: every sample the board recorded, in
  // sequence, with the clock mapping.
  const auto check =
      run_command("/usr/bin/python3 -c \"import h5py, numpy as np; f = h5py.File('" +
                  (dir_ / "remote" / "run.h5").string() +
                  "'); t = f['axes/rotor/sensor/t'][:]; print(f.attrs['status'].decode(), len(t), "
                  "bool(np.all(np.diff(t) > 0)), 'board_clock_offset_ns' in f.attrs, "
                  "f.attrs['stream_gaps_fetched'].decode(), f.attrs['link_outages'].decode())\"");
  // No gap and no outage on an undisturbed link.
  EXPECT_EQ(check.out, fmt::format("completed {} True True none none\n",
                                   r.at("sensor").at("samples").get<long>()))
      << check.err;
}

TEST_F(Piezod, ARequestBeyondTheBoardsLimitsIsRefusedNamingTheKey) {
  start();
  const auto r = run_command(kPiezo + " run --config " + kSimConfig +
                             " --set drive.V_max=100 --set drive.V0=90 --rig " + address_ +
                             " --out " + (dir_ / "refused").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("drive.V0"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("allowed: (0, 80] V"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "refused"));
  EXPECT_EQ(status().at("state"), "idle");
}

TEST_F(Piezod, AnIndependentPythonClientRunsFromTheProtocolDocument) {
  start();
  const auto r =
      run_command("/usr/bin/python3 " + kSource + "/tests/protocol/protocol_client.py " + address_);
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err << log();
  EXPECT_EQ(r.out.substr(0, 3), "ok ") << r.out;
  EXPECT_EQ(status().at("state"), "idle");  // the malformed input did not stop the daemon
}

// Calibrate, then move, by a client written from the protocol document
// alone (on the virtual clock); the board keeps the calibration in its
// [piezod] calibration_file and has it again after a restart.
TEST_F(Piezod, AnIndependentClientCalibratesThenMovesAndTheBoardKeepsIt) {
  const fs::path kept = fresh_temp_dir("calibration-file") / "calibration.json";
  const std::string keep = "calibration_file = \"" + kept.string() + "\"\n";
  start(keep, {"--set", "run.clock=virtual"});
  const auto r = run_command("/usr/bin/python3 " + kSource +
                             "/tests/protocol/calibrate_client.py " + address_);
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err << log();
  EXPECT_EQ(r.out.substr(0, 3), "ok ") << r.out;
  ASSERT_TRUE(fs::exists(kept));
  const auto calibration = [&] {
    const auto said = run_command(kPiezo + " hello --json --rig " + address_);
    EXPECT_EQ(said.exit_code, 0) << said.err;
    return nlohmann::json::parse(said.out).at("axes").at(0).at("calibration");
  };
  const nlohmann::json before = calibration();
  ASSERT_TRUE(before.is_object());
  EXPECT_TRUE(status().at("axes").at(0).at("calibrated").get<bool>());
  daemon_.reset();  // the board goes down
  start(keep, {"--set", "run.clock=virtual"});
  EXPECT_EQ(calibration(), before);
  const auto text = run_command(kPiezo + " status --rig " + address_);
  EXPECT_NE(text.out.find("calibrated " + before.at("created").get<std::string>()),
            std::string::npos)
      << text.out;
}

/// Waits until the board at `address` has been running for `seconds`, as
/// the board itself says: a host slow to start (a loaded machine) has not
/// begun its run after any fixed sleep. One Python client polls, not a
/// `piezo status` each poll: a sanitized `piezo` on a loaded machine takes
/// seconds to start. Returns the board's state when it stopped waiting.
std::string wait_until_into_the_run(const std::string& address, double seconds) {
  const auto r = run_command(
      "/usr/bin/python3 -c \"import zmq, msgpack, time\n"
      "c = zmq.Context().socket(zmq.DEALER); c.setsockopt(zmq.RCVTIMEO, 30000)\n"
      "c.connect('" +
      address +
      "')\n"
      "for i in range(1, 3000):\n"
      "    c.send(msgpack.packb({'id': i, 'cmd': 'status', 'args': {}}))\n"
      "    s = msgpack.unpackb(c.recv())['result']\n"
      "    if s['state'] == 'running' and s['board_ns'] - s['run']['t0_ns'] >= " +
      std::to_string(seconds) +
      " * 1e9: break\n"
      "    time.sleep(0.01)\n"
      "print(s['state'])\"");
  return r.out + r.err;
}

// The host dies mid-run: nothing renews the lease, and the board ramps to
// 0 V, disables and latches link_lost by itself. Checked on the board's
// recorder: the drive's own samples, as the simulated drive acknowledged.
TEST_F(Piezod, KillNineOfTheHostStopsTheBoardAndLatchesLinkLost) {
  start();
  Spawned host({kPiezo, "run", "--config", kSimConfig, "--rig", address_, "--duration", "60",
                "--out", (dir_ / "killed").string()},
               (dir_ / "host.log").string());
  ASSERT_EQ(wait_until_into_the_run(address_, 1.0), "running\n") << read_all(dir_ / "host.log");
  host.signal(SIGKILL);
  EXPECT_EQ(host.wait_exit(), 128 + SIGKILL);
  EXPECT_TRUE(poll_until([&] { return status().at("state") != "running"; }, 30000ms, 100ms));
  const auto s = status();
  EXPECT_EQ(s.at("state"), "fault");
  EXPECT_EQ(s.at("fault"), "link_lost");
  const auto& summary = s.at("run").at("summary");
  EXPECT_EQ(summary.at("cause"), "link_lost");
  EXPECT_EQ(summary.at("output").at("state"), "confirmed");
  EXPECT_NE(log().find("ended: link_lost"), std::string::npos) << log();
  // Within the lease plus the ramp, on the board's clock: from the last
  // sample still driving to the stop.
  const auto fetch = run_command(
      "/usr/bin/python3 -c \"import zmq, msgpack, struct; c = zmq.Context().socket(zmq.DEALER); "
      "c.connect('" +
      address_ + "'); n = " + std::to_string(summary.at("samples").at("drive").get<long>()) +
      "; c.send(msgpack.packb({'id': 1, 'cmd': 'fetch', 'args': {'stream': 'drive', 'first': "
      "n - 5000, 'count': 5000}})); f = msgpack.unpackb(c.recv())['result']['frame']; "
      "r = [struct.unpack_from('<qdBB', f, 24 + 24 * i) for i in range(5000)]; "
      "ramp = [x for x in r if x[2] == 1]; print(len(ramp) > 0, (r[-1][0] - ramp[0][0]) * 1e-9, "
      "r[-1][1], r[-1][2])\"");
  std::istringstream in(fetch.out);
  std::string ramped;
  double stop_s = 0, last_V = -1;
  int last_phase = -1;
  in >> ramped >> stop_s >> last_V >> last_phase;
  EXPECT_EQ(ramped, "True") << fetch.out << fetch.err;
  EXPECT_LT(stop_s, 80.0 / 1000.0 + 0.05);  // V_max / ramp_down_V_per_s, plus the stop's confirm
  EXPECT_EQ(last_V, 0.0);
  EXPECT_EQ(last_phase, 2);  // stopped
  // Nothing resumes by itself: a new start is refused until reset_fault.
  const auto again = run_command(kPiezo + " run --config " + kSimConfig + " --rig " + address_ +
                                 " --duration 0.2 --out " + (dir_ / "again").string());
  EXPECT_NE(again.exit_code, 0);
  EXPECT_NE(again.err.find("reset_fault"), std::string::npos) << again.err;
  EXPECT_EQ(run_command(kPiezo + " reset-fault --rig " + address_).exit_code, 0);
  EXPECT_EQ(status().at("state"), "idle");
}

// On the virtual clock the board waits for a client that renews its lease
// but has not taken care of its samples (a host whose log fell behind). A
// stop (or an e-stop) must still get through: the board never holds back
// the cycle that sees it. The client here never acknowledges anything.
std::string stop_a_run_held_for_its_client(const std::string& address, const std::string& stop) {
  return run_command(
             "/usr/bin/python3 -c \"import zmq, msgpack, time\n"
             "c = zmq.Context().socket(zmq.DEALER); c.connect('" +
             address +
             "')\n"
             "def call(cmd, **a):\n"
             "    c.send(msgpack.packb({'id': 1, 'cmd': cmd, 'args': a}))\n"
             "    assert c.poll(3000), cmd + ': no reply'\n"
             "    return msgpack.unpackb(c.recv())\n"
             "def recorded():\n"
             "    return call('status')['result']['recorder']['drive']['next']\n"
             "call('configure', V0=50.0, f=10.0, duration_s=86000.0)\n"
             "call('start', lease_s=2.0)\n"
             "last, still = -1, 0\n"
             "while still < 5:\n"
             "    call('lease', drive_received=0); time.sleep(0.1); n = recorded()\n"
             "    still, last = (still + 1 if n == last else 0), n\n"
             "held = last\n"
             "call('" +
             stop +
             "')\n"
             "end = time.time() + 20\n"
             "while time.time() < end and not call('status')['result']['run']['finished']:\n"
             "    call('lease', drive_received=0); time.sleep(0.1)\n"
             "run = call('status')['result']['run']\n"
             "print(held >= 200000, run['finished'], run.get('summary', {}).get('cause'), "
             "run.get('summary', {}).get('output', {}).get('state'))\"")
      .out;
}

TEST_F(Piezod, AStopReachesAVirtualClockBoardThatWaitsForItsClient) {
  start("", {"--set", "run.clock=virtual"});
  EXPECT_EQ(stop_a_run_held_for_its_client(address_, "stop"), "True True interrupted confirmed\n")
      << log();
}

TEST_F(Piezod, AnEstopReachesAVirtualClockBoardThatWaitsForItsClient) {
  start("", {"--set", "run.clock=virtual"});
  EXPECT_EQ(stop_a_run_held_for_its_client(address_, "estop"), "True True estop confirmed\n")
      << log();
}

// The board's sensor sits at another radius than the host's config says:
// the samples are the board's, so the angles use its radius (from hello),
// as a one-machine run with that radius does; the host says it differed.
TEST_F(Piezod, AnglesUseTheRadiusOfTheBoardsSensor) {
  start("", {"--set", "run.clock=virtual", "--set", "sensor.r2_m=0.05"});
  const auto hello = run_command(
      "/usr/bin/python3 -c \"import zmq, msgpack; c = zmq.Context().socket(zmq.DEALER); "
      "c.connect('" +
      address_ +
      "'); c.send(msgpack.packb({'id': 1, 'cmd': 'hello'})); "
      "print(msgpack.unpackb(c.recv())['result']['axes'][0]['r2_m'])\"");
  EXPECT_EQ(hello.out, "0.05\n") << hello.err;
  const auto remote = run_command(kPiezo + " run --config " + kSimConfig + " --rig " + address_ +
                                  " --duration 1 --json --out " + (dir_ / "remote").string());
  ASSERT_EQ(remote.exit_code, 0) << remote.err;
  EXPECT_NE(remote.err.find("sensor.r2_m is 0.05 m"), std::string::npos) << remote.err;
  const auto local = run_command(kPiezo + " run --config " + kSimConfig +
                                 " --set run.clock=virtual --set sensor.r2_m=0.05 --duration 1 "
                                 "--json --out " +
                                 (dir_ / "local").string());
  ASSERT_EQ(local.exit_code, 0) << local.err;
  const double theta_r = nlohmann::json::parse(remote.out).at("theta_end_rad");
  const double theta_l = nlohmann::json::parse(local.out).at("theta_end_rad");
  EXPECT_NEAR(theta_r / theta_l, 1.0, 0.03) << theta_r << " vs " << theta_l;
  const auto logged = run_command(
      "/usr/bin/python3 -c \"import h5py; f = h5py.File('" + (dir_ / "remote" / "run.h5").string() +
      "'); print('sensor_geometry_note' in f.attrs, f['axes/rotor/sensor/theta'][-1])\"");
  EXPECT_EQ(logged.out.substr(0, 5), "True ") << logged.out << logged.err;
}

// A watcher floods fetch during someone else's run (300 x 30000 samples,
// sent without waiting): its fetches are held to its budget (1e6 samples/s
// in bursts of 100000), the rest refused rate_limited, and the run ends as
// it would have. (What the flood costs the drive loop is a benchmark's
// figure: tests/bench/bench_fetch_flood.py.)
TEST_F(Piezod, AFetchFloodFromAWatcherIsHeldToItsBudget) {
  start();
  // Long enough that the whole flood meets the run under way, however slow
  // the machine; stopped (Ctrl-C) once the flood is over.
  Spawned host({kPiezo, "run", "--config", kSimConfig, "--rig", address_, "--duration", "120",
                "--json", "--out", (dir_ / "run").string()},
               (dir_ / "host.json").string());
  ASSERT_TRUE(poll_until([&] { return status().at("state") == "running"; }, 30000ms, 20ms));
  std::this_thread::sleep_for(300ms);  // samples to fetch
  const auto flood = run_command("/usr/bin/python3 " + kSource + "/tests/protocol/fetch_flood.py " +
                                 address_ + " 300 30000");
  ASSERT_EQ(flood.exit_code, 0) << flood.err;
  EXPECT_EQ(status().at("state"), "running") << "the flood met the run under way";
  std::istringstream in(flood.out);
  long ok = 0, limited = 0, other = 0;
  double seconds = 0;
  in >> ok >> limited >> other >> seconds;
  EXPECT_GT(limited, 0) << flood.out;
  EXPECT_EQ(other, 0) << flood.out;
  EXPECT_LE(static_cast<double>(ok) * 30000, 100000 + 1e6 * seconds + 30000) << flood.out;
  host.signal(SIGINT);
  EXPECT_EQ(host.wait_exit(), 130) << read_all(dir_ / "host.json");
  const std::string out = read_all(dir_ / "host.json");
  const auto j = nlohmann::json::parse(out.substr(out.find('{')));
  EXPECT_EQ(j.at("stop_cause"), "interrupted") << "the run ended as it would have";
  EXPECT_EQ(j.at("output").at("state"), "confirmed");
}

// Positioning against the board, the host with no config of its own (the
// board has one): moves are absolute from the board's zero, `piezo zero`
// moves the zero, and steps run whole periods.
TEST_F(Piezod, MovesAreAbsoluteFromTheBoardsZeroAndStepsNeedNoHostConfig) {
  start();
  const auto move = [&](const std::string& to) {
    const auto r = run_command(kPiezo + " move --to " + to + " --rig " + address_ +
                               " --json --out " + (dir_ / ("move" + to)).string());
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return nlohmann::json::parse(r.out);
  };
  const auto position = [&] {
    return status().at("axes").at(0).at("position").at("position_rad").get<double>();
  };
  // The move's promise: its own mean at 0 V within the tolerance. The
  // board's position read afterwards is a fresh mean of 8 readings: within
  // the tolerance and four of that mean's standard deviations (the sensor's
  // noise at rest, over the default sensor radius of 62 mm).
  const auto on_target = [&](const nlohmann::json& reply, double target, const char* what) {
    const nlohmann::json& m = reply.at("moves").at(0);
    ASSERT_TRUE(m.at("on_target").get<bool>()) << what;
    const double tolerance = m.at("tolerance_rad").get<double>();
    EXPECT_NEAR(m.at("position_rad").get<double>(), target, tolerance) << what;
    const double eight_readings_rad = m.at("noise_m").get<double>() / 0.062 / std::sqrt(8.0);
    EXPECT_NEAR(position(), target, tolerance + 4 * eight_readings_rad) << what;
  };
  on_target(move("0.001"), 0.001, "from the first zero");
  const auto zeroed = run_command(kPiezo + " zero --rig " + address_);
  EXPECT_EQ(zeroed.exit_code, 0) << zeroed.err;
  // The zero is the mean of the latest 8 readings when it was taken; the
  // board goes on reading at rest, so the position now is a later mean:
  // within four of its standard deviations (8 urad a reading) of 0.
  EXPECT_NEAR(position(), 0.0, 4 * std::sqrt(2.0) * 8.1e-6 / std::sqrt(8.0));
  on_target(move("-0.0005"), -0.0005, "from the new zero");
  const auto step = run_command(kPiezo + " step 2 --rig " + address_ + " --json --out " +
                                (dir_ / "steps").string());
  ASSERT_EQ(step.exit_code, 0) << step.err;
  const auto j = nlohmann::json::parse(step.out);
  EXPECT_EQ(j.at("steps").at("count"), 2);
  EXPECT_GT(j.at("steps").at("travel_rad").get<double>(), 1e-3);
  // No config and no board: the host says what it needs.
  const auto none = run_command(kPiezo + " step 2");
  EXPECT_EQ(none.exit_code, 2);
  EXPECT_NE(none.err.find("--config: required, or --rig ADDRESS"), std::string::npos) << none.err;
}

// The host dies in the middle of a closed-loop move: the board's lease ends
// the move by itself, the drive at 0 V (its own last record, as the
// simulated drive acknowledged it), the move's cause link_lost. A 2 s lease:
// the default 0.5 s can lapse before the kill when a loaded machine starves
// the host.
TEST_F(Piezod, KillNineOfTheHostMidMoveEndsTheMoveAtZeroVoltsWithLinkLost) {
  start();
  Spawned host({kPiezo, "move", "--to", "0.2", "--timeout", "60", "--config", kSimConfig, "--rig",
                address_, "--set", "rig.lease_s=2", "--out", (dir_ / "killed-move").string()},
               (dir_ / "host.log").string());
  // Mid-move: a few coarse steps taken (however long a loaded machine takes
  // to start the host and the move).
  ASSERT_TRUE(poll_until(
      [&] {
        const auto now = status();
        return now.at("state") == "running" && now.at("run").contains("moves") &&
               now.at("run").at("moves").at(0).value("steps", 0) > 3;
      },
      30000ms, 50ms))
      << read_all(dir_ / "host.log");
  host.signal(SIGKILL);
  EXPECT_EQ(host.wait_exit(), 128 + SIGKILL);
  // The lease, then the ramp to 0 V: the fault and the run's summary.
  ASSERT_TRUE(poll_until(
      [&] {
        const auto now = status();
        return now.at("fault").is_string() && now.at("run").contains("summary");
      },
      30000ms, 50ms));
  const auto s = status();
  EXPECT_EQ(s.at("fault"), "link_lost");
  const auto& summary = s.at("run").at("summary");
  const auto& move = summary.at("axes").at(0).at("move");
  EXPECT_EQ(move.at("stop_cause"), "link_lost");
  EXPECT_FALSE(move.at("on_target").get<bool>());
  EXPECT_GT(move.at("steps").get<int>(), 3);
  EXPECT_EQ(summary.at("output").at("state"), "confirmed");
  const long n = summary.at("samples").at("drive").get<long>();
  const auto last = run_command(
      "/usr/bin/python3 -c \"import zmq, msgpack, struct; c = zmq.Context().socket(zmq.DEALER); "
      "c.connect('" +
      address_ +
      "'); c.send(msgpack.packb({'id': 1, 'cmd': 'fetch', 'args': {'stream': 'drive', "
      "'first': " +
      std::to_string(n - 1) +
      ", 'count': 1}})); "
      "f = msgpack.unpackb(c.recv())['result']['frame']; r = struct.unpack_from('<qdBBB', f, 24); "
      "print(r[1], r[2])\"");
  EXPECT_EQ(last.out, "0.0 2\n") << last.err << ": 0 V, stopped";
}

/// A 2 s link outage mid-run through a proxy that drops every connection
/// and refuses new ones (link_proxy.py). Returns the host's summary.
struct OutageRun {
  nlohmann::json summary;
  std::string log_facts;  ///< status, samples, in order, outages marked, gaps fetched
};

OutageRun run_through_an_outage(int board_port, const fs::path& dir, const std::string& extra) {
  const int port = free_port(2);
  Spawned proxy({"/usr/bin/python3", kSource + "/tests/protocol/link_proxy.py",
                 std::to_string(port), std::to_string(board_port), "2.0"},
                (dir / "proxy.log").string());
  EXPECT_TRUE(wait_for_tcp(port));
  Spawned host(
      {kPiezo, "run", "--config", kSimConfig, "--rig", "tcp://127.0.0.1:" + std::to_string(port),
       "--duration", "5", "--json", "--out", (dir / "outage").string(), "--set", extra},
      (dir / "host.txt").string());
  // The link is cut 0.5 s into the board's run: cut before it, the host
  // would fail to connect rather than lose a run.
  EXPECT_EQ(wait_until_into_the_run("tcp://127.0.0.1:" + std::to_string(board_port), 0.5),
            "running\n")
      << read_all(dir / "host.txt");
  proxy.signal(SIGUSR1);
  (void)host.wait_exit();
  OutageRun out;
  std::istringstream lines(read_all(dir / "host.txt"));
  for (std::string line; std::getline(lines, line);) {
    if (!line.empty() && line.front() == '{') out.summary = nlohmann::json::parse(line);
  }
  out.log_facts =
      run_command(
          "/usr/bin/python3 -c \"import h5py, numpy as np; f = h5py.File('" +
          (dir / "outage" / "run.h5").string() +
          "'); a = f.attrs; t = f['axes/rotor/sensor/t'][:]; d = f['axes/rotor/drive/t'][:]; "
          "print(a['status'].decode(), len(t), len(d), bool(np.all(np.diff(t) > 0)), "
          "bool(np.all(np.diff(d) > 0)), a['link_outages'].decode() != 'none', "
          "a['stream_gaps_fetched'].decode() != 'none')\"")
          .out;
  return out;
}

// With a lease longer than the outage the run goes on, and the host's log
// has every sample the board recorded: the gap was fetched and marked.
TEST_F(Piezod, ATwoSecondOutageUnderALongerLeaseLosesNothing) {
  start();
  const auto r = run_through_an_outage(port_, dir_, "rig.lease_s=5");
  ASSERT_FALSE(r.summary.is_null()) << read_all(dir_ / "host.txt");
  EXPECT_EQ(r.summary.at("status"), "completed") << read_all(dir_ / "host.txt");
  const auto board = status();
  const auto& recorded = board.at("run").at("summary").at("samples");
  EXPECT_EQ(r.log_facts,
            fmt::format("completed {} {} True True True True\n", recorded.at("sensor").get<long>(),
                        recorded.at("drive").get<long>()));
}

// With the default 0.5 s lease the board stops by itself (link_lost), and
// after the link returns the host still completes its log up to the stop.
TEST_F(Piezod, ATwoSecondOutageUnderTheDefaultLeaseStopsTheBoard) {
  start();
  const auto r = run_through_an_outage(port_, dir_, "run.flush_interval_s=0.25");
  ASSERT_FALSE(r.summary.is_null()) << read_all(dir_ / "host.txt");
  EXPECT_EQ(r.summary.at("stop_cause"), "link_lost");
  EXPECT_EQ(r.summary.at("output").at("state"), "confirmed");
  EXPECT_LT(r.summary.at("t_end_s").get<double>(), 2.5);
  const auto board = status();
  EXPECT_EQ(board.at("fault"), "link_lost");
  const auto& recorded = board.at("run").at("summary").at("samples");
  EXPECT_EQ(r.log_facts,
            fmt::format("failed {} {} True True True True\n", recorded.at("sensor").get<long>(),
                        recorded.at("drive").get<long>()));
}

// A 2 s run into a 1 s memory ring: the start is gone from memory, and the
// spill file still serves it; without one, the fetch is refused by name.
std::string fetch_the_first_samples(const std::string& address) {
  return run_command(
             "/usr/bin/python3 -c \"import zmq, msgpack, time, struct\n"
             "c = zmq.Context().socket(zmq.DEALER); c.connect('" +
             address +
             "')\n"
             "def call(i, cmd, **a):\n"
             "    c.send(msgpack.packb({'id': i, 'cmd': cmd, 'args': a})); return "
             "msgpack.unpackb(c.recv())\n"
             "call(1, 'configure', V0=50.0, f=10.0, duration_s=2.0)\n"
             "call(2, 'start', lease_s=5.0)\n"
             "while not call(3, 'status')['result']['run']['finished']: time.sleep(0.1)\n"
             "r = call(4, 'fetch', stream='drive', first=0, count=100)\n"
             "print(struct.unpack_from('<QI', r['result']['frame'], 8) if r['ok'] else "
             "r['error']['code'])\"")
      .out;
}

TEST_F(Piezod, TheSpillFileServesWhatTheMemoryRingNoLongerHolds) {
  start("recorder_s = 1.0\nspill_file = \"" + (fresh_temp_dir("spill") / "recorder.bin").string() +
        "\"\n");
  EXPECT_EQ(fetch_the_first_samples(address_), "(0, 100)\n") << log();
}

TEST_F(Piezod, WithoutASpillFileOldSamplesAreRefusedByName) {
  start("recorder_s = 1.0\n");
  EXPECT_EQ(fetch_the_first_samples(address_), "not_available\n") << log();
}

TEST_F(Piezod, ANetworkAddressNeedsCurveAndRefusesUnknownClients) {
  const auto keys = fresh_temp_dir("piezod-keys");
  for (const char* name : {"board", "host", "stranger"}) {
    ASSERT_EQ(run_command(kPiezod + " keygen --out " + keys.string() + " --name " + name).exit_code,
              0);
  }
  write_file(keys / "authorized_keys", read_all(keys / "host.pub"));
  start("secret_key_file = \"" + (keys / "board.key").string() + "\"\n" +
            "authorized_keys_file = \"" + (keys / "authorized_keys").string() + "\"\n",
        {});
  const std::string curve = " --server-key " + (keys / "board.pub").string() + " --client-key ";
  const auto ok = run_command(kPiezo + " status --json --rig " + address_ + curve +
                              (keys / "host.key").string());
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
  const auto refused =
      run_command(kPiezo + " status --rig " + address_ + curve + (keys / "stranger.key").string());
  EXPECT_NE(refused.exit_code, 0);
  EXPECT_NE(refused.err.find("no reply"), std::string::npos) << refused.err;
  EXPECT_NE(log().find("is not in the authorized keys"), std::string::npos) << log();
  // Without keys, a network address is refused at start.
  const auto plain = run_command(
      kPiezod + " --config " + kSource +
      "/configs/piezod-sim.toml --listen tcp://0.0.0.0:" + std::to_string(free_port(2)));
  EXPECT_EQ(plain.exit_code, 1);
  EXPECT_NE(plain.err.find("CURVE"), std::string::npos) << plain.err;
}

// The board's diagnostics: what its configured devices offer, listed
// without starting the daemon (nothing listens, nothing is driven); a bad
// config is refused as it would be at start.
// `piezo status` reads a board of one axis as a board with one axis: the
// same lines, one per axis, whatever the count; a group run's summary says
// how each of its axes ended.
TEST(PiezodStatus, EveryAxisHasItsLineOnABoardOfOneAndOfThree) {
  for (const std::string config : {"piezod-sim.toml", "three-axes.toml"}) {
    SCOPED_TRACE(config);
    const fs::path dir = fresh_temp_dir("status-shape");
    const int port = free_port(2);
    const std::string address = "tcp://127.0.0.1:" + std::to_string(port);
    Spawned board({kPiezod, "--config", kSource + "/configs/" + config, "--listen", address},
                  (dir / "piezod.log").string());
    ASSERT_TRUE(wait_for_tcp(port));
    const bool three = config == "three-axes.toml";
    const std::string move = three ? " --to theta=0.002 --to phi=-0.001" : " --to 0.002";
    const auto moved =
        run_command(kPiezo + " move --rig " + address + move + " --out " + (dir / "move").string());
    ASSERT_EQ(moved.exit_code, 0) << moved.err;
    const auto status = run_command(kPiezo + " status --rig " + address);
    ASSERT_EQ(status.exit_code, 0) << status.err;
    const std::vector<std::string> axes =
        three ? std::vector<std::string>{"theta", "phi", "chi"} : std::vector<std::string>{"rotor"};
    for (const std::string& axis : axes) {
      EXPECT_TRUE(std::regex_search(status.out, std::regex("\\naxis " + axis + " +")))
          << status.out;
    }
    for (const std::string& moved_axis :
         three ? std::vector<std::string>{"theta", "phi"} : std::vector<std::string>{"rotor"}) {
      EXPECT_TRUE(std::regex_search(
          status.out, std::regex("  axis " + moved_axis + " +completed, move on_target")))
          << status.out;
    }
    EXPECT_EQ(status.out.find("position   "), std::string::npos) << "no first-axis mirror";
  }
}

TEST(PiezodDevices, ListsTheConfiguredDevicesAndExits) {
  const std::string config = kSource + "/configs/piezod-sim.toml";
  const auto r = run_command(kPiezod + " devices --config " + config);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* kind : {"drive (sim): ", "sensor (sim): ", "lines (sim): "}) {
    EXPECT_NE(r.out.find(kind), std::string::npos) << kind << " in\n" << r.out;
  }
  const auto before = run_command(kPiezod + " --config " + config + " devices");
  EXPECT_EQ(before.out, r.out) << "the options before or after the subcommand";
  const auto bad = run_command(kPiezod + " devices --config " + config + " --set drive.V_max=1e9");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("drive.V_max"), std::string::npos) << bad.err;
}

}  // namespace
}  // namespace piezo::testing

namespace piezo::testing {
namespace {

// As ssh does: a secret key file others can read is refused, by the board
// and by the host; keygen never replaces a pair without --force.
TEST(PiezodConfig, ASecretKeyOthersCanReadIsRefusedAndKeygenKeepsAPair) {
  const auto keys = fresh_temp_dir("piezod-key-modes");
  const std::string keygen = kPiezod + " keygen --out " + keys.string() + " --name board";
  ASSERT_EQ(run_command(keygen).exit_code, 0);
  EXPECT_EQ(fs::status(keys / "board.key").permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write);
  const std::string first = read_all(keys / "board.key");
  const auto again = run_command(keygen);
  EXPECT_EQ(again.exit_code, 1);
  EXPECT_NE(again.err.find("exists; keygen --force"), std::string::npos) << again.err;
  EXPECT_EQ(read_all(keys / "board.key"), first) << "a refused keygen kept the pair";
  ASSERT_EQ(run_command(keygen + " --force").exit_code, 0);
  EXPECT_NE(read_all(keys / "board.key"), first);
  fs::permissions(keys / "board.key", fs::perms::group_read | fs::perms::others_read,
                  fs::perm_options::add);
  write_file(keys / "authorized_keys", read_all(keys / "board.pub"));
  const auto board = run_command(
      kPiezod + " --config " + kSource +
      "/configs/piezod-sim.toml --listen tcp://127.0.0.1:" + std::to_string(free_port(2)) +
      " --set piezod.secret_key_file=\"" + (keys / "board.key").string() +
      "\" --set piezod.authorized_keys_file=\"" + (keys / "authorized_keys").string() + "\"");
  EXPECT_NE(board.exit_code, 0);
  EXPECT_NE(board.err.find("readable by others (mode 0644)"), std::string::npos) << board.err;
  const auto host = run_command(
      kPiezo + " status --rig tcp://127.0.0.1:" + std::to_string(free_port(2)) + " --server-key " +
      (keys / "board.pub").string() + " --client-key " + (keys / "board.key").string());
  EXPECT_NE(host.exit_code, 0);
  EXPECT_NE(host.err.find("chmod 600"), std::string::npos) << host.err;
}

// Loopback by name and over IPv6 is bound like 127.0.0.1 (no keys needed),
// and a client reaches the daemon there.
TEST(PiezodConfig, LocalhostAndIpv6LoopbackCanBeBound) {
  for (const std::string host : {"localhost", "[::1]"}) {
    SCOPED_TRACE(host);
    const int port = free_port(2);
    const std::string address = "tcp://" + host + ":" + std::to_string(port);
    const auto dir = fresh_temp_dir("piezod-loopback");
    Spawned daemon({kPiezod, "--config", kSource + "/configs/piezod-sim.toml", "--listen", address},
                   (dir / "piezod.log").string());
    nlohmann::json status;
    for (int i = 0; i < 20 && status.is_null(); ++i) {
      std::this_thread::sleep_for(100ms);
      const auto r = run_command(kPiezo + " status --json --rig " + address);
      if (r.exit_code == 0) status = nlohmann::json::parse(r.out);
    }
    EXPECT_EQ(status.value("state", std::string()), "idle") << read_all(dir / "piezod.log");
  }
}

// A listen address piezod cannot serve is a config error like any other:
// exit 2, naming piezod.listen and where it came from.
TEST(PiezodConfig, AnAddressItCannotServeIsRefusedByKeyAndFile) {
  const std::string config = kSource + "/configs/piezod-sim.toml";
  const auto in_file = run_command(kPiezod + " --config " + config + " --set piezod.listen=abc");
  EXPECT_EQ(in_file.exit_code, 2) << in_file.err;
  EXPECT_NE(in_file.err.find(config + ": piezod.listen: \"abc\" is not an address"),
            std::string::npos)
      << in_file.err;
  const auto on_line = run_command(kPiezod + " --config " + config + " --listen tcp://nowhere");
  EXPECT_EQ(on_line.exit_code, 2) << on_line.err;
  EXPECT_NE(on_line.err.find("--listen: piezod.listen:"), std::string::npos) << on_line.err;
}

}  // namespace
}  // namespace piezo::testing
