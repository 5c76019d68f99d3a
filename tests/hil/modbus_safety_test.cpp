// How a run over real Modbus links ends, seen from the device: rig-sim's
// analog-output register, read after the run by mbpoll (an independent
// peer), never only what the firmware logged. Signals, a closed pipe, a
// drive that stops answering for a while or for good, a full disk, a late
// reply, and configs that would leave a dead link unguarded.

#include <gtest/gtest.h>

#include <csignal>
#include <nlohmann/json.hpp>

#include "../support/rig_sim.hpp"
#include "build_paths.hpp"
#include "piezo/hal/modbus/link.hpp"
#include "piezo/hal/modbus/register_map.hpp"

namespace piezo::testing {
namespace {

class ModbusSafety : public ModbusHil {
 protected:
  /// rig-sim's analog-output holding register, which must be readable.
  int ao_register() const {
    const int counts = read_ao_register();
    EXPECT_GE(counts, 0) << "mbpoll could not read rig-sim's analog output";
    return counts;
  }

  std::vector<std::string> run_args(const std::string& duration,
                                    const std::vector<std::string>& extra = {}) const {
    std::vector<std::string> args{kPiezo,
                                  "run",
                                  "--config",
                                  kConfig,
                                  "--duration",
                                  duration,
                                  "--set",
                                  "sensor.modbus.port=" + std::to_string(port),
                                  "--set",
                                  "drive.modbus-ao.port=" + std::to_string(port),
                                  "--json",
                                  "--out",
                                  (dir / "run").string()};
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  }

  std::string shell_run(const std::string& duration, const std::string& extra = "") const {
    std::string command;
    for (const auto& a : run_args(duration)) command += "'" + a + "' ";
    return command + extra;
  }

  /// The log's status, output state and last drive record, via h5py.
  std::string log_ending() const {
    const auto r = run_command(
        "/usr/bin/python3 -c \"import h5py; f = h5py.File('" + (dir / "run" / "run.h5").string() +
        "', 'r'); a = f.attrs; print(a['status'].decode(), a['output'].decode() if 'output' in a "
        "else '-', f['axes/rotor/drive/V'][-1], float(f['axes/rotor/drive/phase'][-1]))\"");
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return r.out;
  }

  nlohmann::json summary_in(const fs::path& file) const {
    std::ifstream in(file);
    std::string line, last_json;
    while (std::getline(in, line))
      if (!line.empty() && line.front() == '{') last_json = line;
    return last_json.empty() ? nlohmann::json{} : nlohmann::json::parse(last_json);
  }
};

class StoppingSignal : public ModbusSafety, public ::testing::WithParamInterface<int> {};

// Each signal a user, a terminal or a dropped SSH session can send ends the
// run like SIGINT: ramp, 0 V acknowledged, log closed "interrupted".
TEST_P(StoppingSignal, RampsDownAndLeavesTheOutputAtZero) {
  auto rig = start_rig_sim();
  ASSERT_TRUE(wait_for_tcp(port));
  Spawned run(run_args("30"), (dir / "run.txt").string());
  // However long a loaded machine takes to get the run driving.
  ASSERT_TRUE(wait_for_drive()) << "driving before the signal";
  run.signal(GetParam());
  EXPECT_EQ(run.wait_exit(), 130);
  EXPECT_EQ(ao_register(), 0) << "the module holds 0 V";
  EXPECT_EQ(log_ending(), "interrupted confirmed 0.0 2.0\n");
  const auto j = summary_in(dir / "run.txt");
  EXPECT_EQ(j.at("stop_signal"), std::string("SIG") + sigabbrev_np(GetParam()));
}

INSTANTIATE_TEST_SUITE_P(Signals, StoppingSignal,
                         ::testing::Values(SIGHUP, SIGQUIT, SIGTSTP, SIGUSR1),
                         [](const auto& signal_info) {
                           return std::string(sigabbrev_np(signal_info.param));
                         });

// `piezo run ... 2>&1 | head -n1`: the reader goes away after one line. The
// run must not die of SIGPIPE mid-drive; it goes on to its end.
TEST_F(ModbusSafety, AClosedPipeDoesNotStopTheRun) {
  auto rig = start_rig_sim();
  ASSERT_TRUE(wait_for_tcp(port));
  const fs::path script = dir / "pipe.sh";
  write_file(script, shell_run("2") + "2>&1 | head -n1\nexit ${PIPESTATUS[0]}\n");
  const auto r = run_command("bash " + script.string());
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_EQ(ao_register(), 0);
  EXPECT_EQ(log_ending(), "completed confirmed 0.0 2.0\n");
}

// The module stops answering for 0.3 s: the drive faults, the enable path
// (none here) drops, and the stop keeps writing 0 V until the module takes it.
TEST_F(ModbusSafety, AHungDriveIsZeroedOnceItAnswersAgain) {
  auto rig = start_rig_sim({"--set", "rig_sim.hang_at_s=1", "--set", "rig_sim.hang_for_s=0.3",
                            "--set", "rig_sim.times_from_drive=true"});
  ASSERT_TRUE(wait_for_tcp(port));
  const auto r = run_command(shell_run("30", "--set safety.stop_confirm_s=3"));
  EXPECT_EQ(r.exit_code, 1) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("status"), "failed");
  EXPECT_EQ(j.at("output").at("state"), "confirmed");
  EXPECT_GT(j.at("output").at("zero_writes").get<int>(), 1) << "0 V needed retries";
  EXPECT_EQ(ao_register(), 0) << "the device holds 0 V";
  EXPECT_EQ(log_ending(), "failed confirmed 0.0 2.0\n");
}

// The module never answers again within the bound: the run says so plainly
// and logs the last value the module acknowledged, not a 0 V it never took;
// the module's own watchdog is what zeroes it.
TEST_F(ModbusSafety, ADeadDriveIsReportedUnconfirmedAndItsWatchdogZeroesIt) {
  // The hang comes 1.05 s into the drive, mid-rise (not into rig-sim's life:
  // a run on a loaded machine may take seconds to start, and a hang before
  // its first write, or at a period's start, would leave 0 V acknowledged).
  auto rig = start_rig_sim({"--set", "rig_sim.hang_at_s=1.05", "--set", "rig_sim.hang_for_s=3",
                            "--set", "rig_sim.times_from_drive=true"});
  ASSERT_TRUE(wait_for_tcp(port));
  const auto r = run_command(shell_run("30", "--set safety.stop_confirm_s=0.5"));
  // The run ends after the hang began: the hang is over within 3 s of that.
  const auto hang_over = std::chrono::steady_clock::now() + 3500ms;
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("OUTPUT UNCONFIRMED"), std::string::npos) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("output").at("state"), "output_unconfirmed");
  const double acknowledged = j.at("output").at("last_acknowledged_V").get<double>();
  EXPECT_GT(acknowledged, 0.0);
  const auto ending = log_ending();
  EXPECT_EQ(ending.substr(0, ending.find(' ', 7)), "failed output_unconfirmed") << ending;
  EXPECT_NE(ending.find(" 3.0"), std::string::npos) << ending;
  EXPECT_EQ(ending.find(" 0.0 "), std::string::npos) << "never a 0 V it did not reach: " << ending;
  std::this_thread::sleep_until(hang_over);
  EXPECT_EQ(ao_register(), 0) << "the module's watchdog zeroed the output";
}

// The disk fills (a file-size limit of 2.6 MB: the first flush fits, the
// log's reserve for closing does not let a second one start): the drive
// stops, the process exits 1 with the cause, the module holds 0 V, and the
// log holds what was flushed, closed and marked failed.
TEST_F(ModbusSafety, AFullDiskStopsTheDriveAndKeepsTheLogReadable) {
  auto rig = start_rig_sim();
  ASSERT_TRUE(wait_for_tcp(port));
  const fs::path script = dir / "full-disk.sh";
  write_file(script, "ulimit -f 2600\n" + shell_run("30") + "\n");
  const auto r = run_command("timeout 60 bash " + script.string());
  EXPECT_EQ(r.exit_code, 1) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("status"), "failed");
  EXPECT_EQ(j.at("stop_cause"), "log_failed");
  EXPECT_NE(r.err.find("bytes left"), std::string::npos) << r.err;
  EXPECT_EQ(ao_register(), 0);
  const auto ending = log_ending();
  EXPECT_EQ(ending.rfind("failed confirmed", 0), 0u) << ending;
}

// With no enable line, only the module's watchdog can end the drive when the
// link dies: a config without one (or an explicit acceptance) is refused.
TEST_F(ModbusSafety, AnUnguardedAnalogOutputIsRefused) {
  const fs::path config = dir / "unguarded.toml";
  std::ifstream in(kConfig);
  std::string text, line;
  while (std::getline(in, line))
    if (line.rfind("watchdog_", 0) != 0) text += line + "\n";
  write_file(config, text);
  const auto r = run_command(kPiezo + " run --config " + config.string() + " --out " +
                             (dir / "never").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("drive.modbus-ao.watchdog_registers"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "never"));
  // Accepting the risk in the config lets it through the check (it then
  // fails only for want of a module to talk to).
  const auto accepted = run_command(kPiezo + " run --config " + config.string() +
                                    " --set drive.modbus-ao.link_loss_acknowledged=true --set "
                                    "drive.modbus-ao.port=1 --out " +
                                    (dir / "never").string());
  EXPECT_EQ(accepted.exit_code, 1) << accepted.err;
  EXPECT_NE(accepted.err.find("cannot connect"), std::string::npos) << accepted.err;
}

TEST_F(ModbusSafety, CountsBeyondTheRegisterAreRefused) {
  const auto r =
      run_command(kPiezo + " run --config " + kConfig +
                  " --set drive.modbus-ao.counts_per_V=10000 --out " + (dir / "never").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("drive.modbus-ao.counts_per_V"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("65535"), std::string::npos) << r.err;
}

/// Whether process `pid` holds `path` (resolved through its links) open.
bool holds_open(pid_t pid, const fs::path& path) {
  std::error_code ec;
  const fs::path target = fs::canonical(path, ec);
  if (ec) return false;
  for (const auto& fd : fs::directory_iterator("/proc/" + std::to_string(pid) + "/fd", ec)) {
    std::error_code unreadable;
    if (fs::read_symlink(fd.path(), unreadable) == target) return true;
  }
  return false;
}

/// Reads alternately the sensor (input 202-203, about 70 mm) and two idle
/// input registers (0-1, always zero) after one reply came late: no answer
/// may belong to another request. The link waits 0.2 s for a reply, and
/// rig-sim's late one comes 0.35 s late: a loaded machine's delays stay well
/// inside the one, the late reply well outside it.
void expect_no_shifted_replies(hal::modbus::LinkSettings settings) {
  settings.response_timeout_s = 0.2;
  hal::modbus::Link link(settings);
  std::array<std::uint16_t, 2> words{};
  // The first request's reply is the late one.
  EXPECT_EQ(link.read(hal::modbus::Function::input, 1, 202, 2, words.data()), hal::Status::timeout);
  int ok = 0;
  for (int i = 0; i < 40; ++i) {
    const bool sensor = i % 2 == 0;
    words = {0xDEAD, 0xBEEF};
    const hal::Status s =
        link.read(hal::modbus::Function::input, 1, sensor ? 202 : 0, 2, words.data());
    if (s != hal::Status::ok) continue;
    ++ok;
    const double mm =
        hal::modbus::decode(hal::modbus::RegisterType::f32, hal::modbus::WordOrder::CDAB, words);
    if (sensor) {
      EXPECT_NEAR(mm, 70.0, 0.01) << "request " << i;
    } else {
      EXPECT_EQ(words[0] | words[1], 0) << "request " << i << " got another request's reply";
    }
    std::this_thread::sleep_for(5ms);
  }
  EXPECT_GE(ok, 38) << "the link resynchronised after the late reply";
}

TEST_F(ModbusSafety, ALateTcpReplyIsNeverTakenForTheNextOne) {
  auto rig =
      start_rig_sim({"--set", "rig_sim.late_reply_at_s=0", "--set", "rig_sim.late_reply_s=0.35"});
  ASSERT_TRUE(wait_for_tcp(port));
  hal::modbus::LinkSettings settings;
  settings.port = port;
  expect_no_shifted_replies(settings);
}

TEST_F(ModbusRtu, ALateRtuReplyIsNeverTakenForTheNextOne) {
  auto rig = start_rig_sim({"--rtu", (dir / "ptyA").string(), "--set", "rig_sim.late_reply_at_s=0",
                            "--set", "rig_sim.late_reply_s=0.35"});
  // Nothing is sent before rig-sim holds its end open: requests written
  // before would wait in the pty and be answered in a burst when it opens,
  // which no Modbus RTU client can tell from answers to later requests (a
  // real serial line keeps no such backlog).
  ASSERT_TRUE(poll_until([&] { return holds_open(rig->pid(), dir / "ptyA"); }, 30'000ms));
  hal::modbus::LinkSettings settings;
  settings.transport = hal::modbus::LinkSettings::Transport::rtu;
  settings.device = (dir / "ptyB").string();
  expect_no_shifted_replies(settings);
}

// piezod on the Modbus backends against rig-sim, driven over the protocol
// by `piezo run --rig`: the run completes and the module holds 0 V; then a
// host killed with -9 leaves the board to stop by itself, and the module's
// register -- not the firmware's belief -- shows 0 V with link_lost latched.
TEST_F(ModbusSafety, PiezodOnModbusStopsItselfWhenTheHostDies) {
  auto rig = start_rig_sim();
  ASSERT_TRUE(wait_for_tcp(port));
  const int board_port = free_port(2);
  const std::string address = "tcp://127.0.0.1:" + std::to_string(board_port);
  Spawned board({build_paths::piezod, "--config", kConfig, "--set",
                 "sensor.modbus.port=" + std::to_string(port), "--set",
                 "drive.modbus-ao.port=" + std::to_string(port), "--listen", address},
                (dir / "piezod.txt").string());
  ASSERT_TRUE(wait_for_tcp(board_port));

  const auto r = run_command(kPiezo + " run --config " + kConfig + " --rig " + address +
                             " --duration 2 --json --out " + (dir / "run").string());
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  EXPECT_EQ(nlohmann::json::parse(r.out).at("status"), "completed");
  EXPECT_EQ(ao_register(), 0);
  EXPECT_EQ(log_ending(), "completed confirmed 0.0 2.0\n");

  Spawned host({kPiezo, "run", "--config", kConfig, "--rig", address, "--duration", "30", "--out",
                (dir / "killed").string()},
               (dir / "host.txt").string());
  ASSERT_TRUE(wait_for_drive()) << "driving before the kill";
  host.signal(SIGKILL);
  (void)host.wait_exit();
  // The lease lapses and the board stops by itself; how soon is the HIL
  // board's test (piezod_hil_test), not this one's on a loaded machine.
  std::string fault;
  EXPECT_TRUE(poll_until(
      [&] {
        const auto s = run_command(kPiezo + " status --json --rig " + address);
        if (s.exit_code != 0) return false;
        fault = nlohmann::json::parse(s.out).at("fault").dump();
        return fault != "null";
      },
      30000ms, 100ms));
  EXPECT_EQ(fault, "\"link_lost\"");
  EXPECT_EQ(ao_register(), 0) << "the module holds 0 V";
}

}  // namespace
}  // namespace piezo::testing
