// `piezo run` and `piezo report` as people use them: a run's log read by an
// independent reader (h5py), bad input refused before anything starts, and
// runs ended by SIGINT and by kill -9.

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>

#include "../support/run_command.hpp"
#include "../support/spawn.hpp"
#include "build_paths.hpp"

namespace piezo::testing {
namespace {

namespace fs = std::filesystem;
const std::string kPiezo = build_paths::piezo;
const std::string kSimConfig = std::string(build_paths::source_dir) + "/configs/sim.toml";

/// Checks a log with h5py (Debian's python3-h5py); prints "ok" and facts.
CommandResult h5py_check(const fs::path& log, const std::string& body) {
  const fs::path script = log.parent_path() / "check.py";
  write_file(script, "import h5py, math, sys\nf = h5py.File(sys.argv[1], 'r')\n" + body);
  return run_command("/usr/bin/python3 " + script.string() + " " + log.string());
}

TEST(RunCli, VirtualRunWritesALogH5pyReadsAndAReport) {
  const auto dir = fresh_temp_dir("run-virtual");
  const auto out = dir / "run1";
  const auto r = run_command(kPiezo + " run --config " + kSimConfig +
                             " --set run.clock=virtual --duration 1 --json --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("status"), "completed");
  EXPECT_GE(j.at("drive").at("samples").get<int>(), 10'000);
  EXPECT_EQ(j.at("drive").at("overruns").get<int>(), 0);
  EXPECT_TRUE(j.at("drive").at("period_error_us").contains("p99"));
  EXPECT_GE(j.at("sensor").at("samples").get<int>(), 1'000);
  EXPECT_EQ(j.at("sensor").at("errors").get<int>(), 0);
  EXPECT_EQ(j.at("sensor").at("dropped").get<int>(), 0);
  EXPECT_GT(j.at("theta_end_rad").get<double>(), 0.0);
  EXPECT_GT(j.at("mean_velocity_rad_s").get<double>(), 0.0);
  // Every axis of the run, a board of one as of several.
  ASSERT_EQ(j.at("axes").size(), 1u) << j.dump();
  EXPECT_EQ(j.at("axes")[0].at("name"), "rotor");
  EXPECT_EQ(j.at("axes")[0].at("theta_end_rad"), j.at("theta_end_rad"));
  EXPECT_EQ(j.at("axes")[0].at("stop_cause"), "completed");

  const auto check = h5py_check(out / "run.h5", R"(
for name in ['axes/rotor/drive/t', 'axes/rotor/drive/V', 'axes/rotor/sensor/t', 'axes/rotor/sensor/theta']:
    d = f[name]
    assert d.dtype == 'float64' and d.ndim == 1, name
assert len(f['axes/rotor/drive/t']) == len(f['axes/rotor/drive/V']) > 10000
assert len(f['axes/rotor/sensor/t']) == len(f['axes/rotor/sensor/theta']) >= 1000
assert f.attrs['status'].decode() == 'completed'
assert '[drive]' in f.attrs['config'].decode()
assert abs(f['axes/rotor/sensor/theta'][-1] - float(sys.argv[2] if len(sys.argv) > 2 else f['axes/rotor/sensor/theta'][-1])) < 1e-12
assert max(f['axes/rotor/drive/V']) <= 80.0
print('ok')
)");
  EXPECT_EQ(check.exit_code, 0) << check.err;
  EXPECT_EQ(check.out, "ok\n");
  EXPECT_TRUE(fs::exists(out / "config.toml"));
  EXPECT_TRUE(fs::exists(dir / "catalogue.csv"));

  const auto report = run_command(kPiezo + " report " + out.string() + " --json");
  ASSERT_EQ(report.exit_code, 0) << report.err;
  const auto rj = nlohmann::json::parse(report.out);
  for (const char* png : {"angle_png", "zoom_png", "timing_png"}) {
    EXPECT_GT(fs::file_size(rj.at(png).get<std::string>()), 1000u) << png;
  }
  EXPECT_LT(rj.at("rmse_model_rad").get<double>(), 20e-6);
}

// A loaded machine's log has gaps where samples were dropped, a run that
// fell behind logs its drive ahead of its sensor, and a recovered log may
// have lost the end of either: the zoom still shows both.
TEST(ReportCli, ZoomsWhereBothTheDriveAndTheAngleWereLogged) {
  const auto dir = fresh_temp_dir("report-sensor-gaps");
  const auto out = dir / "run";
  const auto r = run_command(kPiezo + " run --config " + kSimConfig +
                             " --set run.clock=virtual --duration 1 --json --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto cut = h5py_check(out / "run.h5", R"(
f.close()
f = h5py.File(sys.argv[1], 'r+')
def keep(group, rows):
    for column in f['axes/rotor/' + group].values():
        kept = column[:][rows]
        column.resize((len(kept),))
        column[:] = kept
drive_t, sensor_t = f['axes/rotor/drive/t'][:], f['axes/rotor/sensor/t'][:]
keep('drive', drive_t < 0.95)
# the sensor's samples lost for five drive periods around the drive's middle,
# and its last 0.1 s
gone = ((sensor_t > 0.3) & (sensor_t < 0.8)) | (sensor_t > 0.9)
keep('sensor', ~gone)
keep('observer', ~gone)
print('ok')
)");
  ASSERT_EQ(cut.out, "ok\n") << cut.err;
  const auto report = run_command(kPiezo + " report " + out.string() + " --json");
  ASSERT_EQ(report.exit_code, 0) << report.err;
  const auto zoom = nlohmann::json::parse(report.out).at("zoom_png").get<std::string>();
  EXPECT_GT(fs::file_size(zoom), 1000u);
}

struct BadRun {
  const char* name;
  std::string args;    // after --config
  std::string config;  // a config text; empty: configs/sim.toml
  std::string expect;  // in stderr
};

void PrintTo(const BadRun& bad, std::ostream* os) {
  *os << bad.name;
}

class RunBadInput : public ::testing::TestWithParam<BadRun> {};

TEST_P(RunBadInput, ExitsWithCode2NamesTheKeyAndLeavesNothing) {
  const BadRun& bad = GetParam();
  const auto dir = fresh_temp_dir(std::string("run-bad-") + bad.name);
  std::string config = kSimConfig;
  if (!bad.config.empty()) {
    config = (dir / "rig.toml").string();
    write_file(config, bad.config);
  }
  const auto out = dir / "run";
  const auto r =
      run_command(kPiezo + " run --config " + config + " " + bad.args + " --out " + out.string());
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find(bad.expect), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out)) << "a refused run leaves no directory";
  EXPECT_FALSE(fs::exists(dir / "catalogue.csv"));
}

const std::string kMinimal = "[drive]\n[sensor]\n[run]\nclock = \"virtual\"\n";

INSTANTIATE_TEST_SUITE_P(
    Cli, RunBadInput,
    ::testing::Values(
        BadRun{"V0AboveLimit", "--set drive.V0=90", "",
               "--set: drive.V0: 90 V is outside the drive's limits; allowed: (0, 80] V (V_max"},
        // Refused here, as the board would, before a run directory exists.
        BadRun{"V0Zero", "--set drive.V0=0", "",
               "--set: drive.V0: 0 V is outside the drive's limits; allowed: (0, 80] V"},
        BadRun{"TargetDistanceZero", "--set sensor.sim.target_distance_m=0", "",
               "--set: sensor.sim.target_distance_m: value 0 m is outside the allowed range (0, "
               "10] m"},
        BadRun{"TargetDistanceNegative", "--set sensor.sim.target_distance_m=-0.05", "",
               "sensor.sim.target_distance_m: value -0.05 m is outside the allowed range"},
        BadRun{"NulInAString", "", kMinimal + "[piezod]\nspill_file = \"a\\u0000b\"\n",
               "rig.toml: piezod.spill_file: must not contain control characters (U+0000 at "
               "character 2)"},
        BadRun{"DuplicateSection", "", kMinimal + "[drive]\n", "rig.toml: line"},
        BadRun{"V0AboveLimitInFile", "", "[drive]\nV0 = 95.0\n[sensor]\n[run]\n",
               "rig.toml: drive.V0: 95 V is outside the drive's limits"},
        BadRun{"VmaxAboveHardware", "--set drive.V_max=120", "",
               "drive.V_max: [0, 120] V exceeds what the drive hardware can produce, [0, 100] V"},
        BadRun{"NaN", "--set sensor.sim.noise_m=nan", "",
               "--set: sensor.sim.noise_m: value nan m is outside the allowed range [0, 1] m"},
        BadRun{"Negative", "--set drive.f=-3", "", "--set: drive.f: value -3"},
        BadRun{"NegativeRate", "--set drive.rate_hz=-10", "",
               "drive.rate_hz: value -10 Hz is outside the allowed range [100, 100000] Hz"},
        BadRun{"UnknownKey", "--set sensor.nosie_m=1e-6", "",
               "--set: sensor.nosie_m: unknown key (allowed: backend, rate_hz"},
        // A backend's keys live in its own section; an old file's are
        // refused naming the new place (both, where one key served two).
        BadRun{"MovedKey", "--set drive.ao_port=1502", "",
               "--set: drive.ao_port: has moved: it is now drive.modbus-ao.port (key `port` in "
               "[drive.modbus-ao])"},
        BadRun{"MovedSharedKey", "", "[drive]\ndac_full_scale_V = 5.0\n[sensor]\n[run]\n",
               "rig.toml: drive.dac_full_scale_V: has moved: it is now drive.sim.dac_full_scale_V "
               "(key `dac_full_scale_V` in [drive.sim]) or drive.gpiod-dac.full_scale_V"},
        BadRun{"UnknownBackendKey", "--set drive.sim.bits=16", "",
               "--set: drive.sim.bits: unknown key (allowed: dac_bits, dac_full_scale_V"},
        BadRun{"BackendSectionNotATable", "--set sensor.modbus=3", "",
               "--set: sensor.modbus: must be a table ([sensor.modbus])"},
        BadRun{"UnknownKeyInFile", "", kMinimal + "[safety]\nramp = 3\n",
               "rig.toml: safety.ramp: unknown key"},
        BadRun{"UnknownSection", "", kMinimal + "[amp]\ngain = 20\n",
               "rig.toml: amp: unknown section"},
        BadRun{"MissingSection", "", "[drive]\n[run]\n",
               "rig.toml: sensor: missing section [sensor] (required: [drive], [sensor], [run])"},
        BadRun{"NotANumber", "--set drive.V0=high", "", "--set: drive.V0: must be a number"},
        BadRun{"BadSetSyntax", "--set V0=70", "", "--set: V0=70: expected SECTION.KEY=VALUE"},
        BadRun{"BadClock", "--set run.clock=fast", "",
               "run.clock: must be one of: \"realtime\", \"virtual\""},
        // The board's rule: the waveform asked for must fit the slew limit.
        BadRun{"SlewTooLow", "--set drive.slew_V_per_s=1000", "",
               "drive.V0: the sawtooth's fastest edge, V0*f/min(D, 1-D) = 3194 V/s, exceeds the "
               "slew limit slew_V_per_s = 1000 V/s"},
        BadRun{"BadPlant", "--set plant.mu=-0.1", "", "plant.mu"},
        BadRun{"RampTooSlow", "--set safety.ramp_down_V_per_s=1e-3", "",
               "safety.ramp_down_V_per_s: 0.001 V/s takes 8e+04 s to ramp from drive.V_max = 80 "
               "V; allowed: >= 40 V/s"},
        BadRun{"StopConfirmTooLong", "--set safety.stop_confirm_s=100", "",
               "safety.stop_confirm_s"},
        BadRun{"BadDirection", "", "[drive]\ndirection = \"sideways\"\n[sensor]\n[run]\n",
               "rig.toml: drive.direction: must be one of: \"forward\", \"reverse\""},
        BadRun{"SensorRegisterPastTheTable",
               "--set sensor.modbus.type=\"f32\" --set sensor.modbus.address=65535", "",
               "sensor.modbus.address: 65535 with a 2-register value runs past register 65535"}),
    [](const auto& param_info) { return std::string(param_info.param.name); });

// `piezo step`: N whole periods on the virtual clock, the travel in the
// JSON is the measured angle, and bad input names its key and leaves nothing.
TEST(RunCli, StepReportsTheMeasuredTravelAndRefusesBadInputByKey) {
  const auto dir = fresh_temp_dir("step-cli");
  const auto r = run_command(kPiezo + " step 3 --reverse --config " + kSimConfig +
                             " --set run.clock=virtual --json --out " + (dir / "steps").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  const auto& steps = j.at("steps");
  EXPECT_EQ(steps.at("count"), 3);
  EXPECT_EQ(steps.at("direction"), "reverse");
  EXPECT_DOUBLE_EQ(steps.at("travel_rad").get<double>(), j.at("theta_end_rad").get<double>());
  EXPECT_LT(steps.at("travel_rad").get<double>(), -1e-3) << "three steps back, about 1.3 mrad each";
  EXPECT_NEAR(steps.at("mean_step_rad").get<double>(), steps.at("travel_rad").get<double>() / 3,
              1e-12);
  EXPECT_NEAR(j.at("t_end_s").get<double>(), 0.3, 2e-3) << "three periods at 10 Hz";

  const auto bad = run_command(kPiezo + " step 3 --V0 120 --config " + kSimConfig + " --out " +
                               (dir / "bad").string());
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("drive.V0: 120 V is outside"), std::string::npos) << bad.err;
  EXPECT_FALSE(fs::exists(dir / "bad"));
  const auto zero = run_command(kPiezo + " step 0 --config " + kSimConfig);
  EXPECT_NE(zero.exit_code, 0);
  EXPECT_NE(zero.err.find("count"), std::string::npos) << zero.err;
}

// `piezo move` on the one-machine default: the JSON the issue names, and a
// bad argument refused by name before anything is created.
TEST(RunCli, MovePrintsItsResultAndRefusesBadArgumentsByName) {
  const auto dir = fresh_temp_dir("move-cli");
  const auto r = run_command(kPiezo + " move --to -0.002 --config " + kSimConfig +
                             " --set run.clock=virtual --json --out " + (dir / "move").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  for (const char* key : {"on_target", "time_s", "stop_cause", "run_dir", "log", "run", "moves"}) {
    EXPECT_TRUE(j.contains(key)) << key;
  }
  // One shape for one axis as for several: the move's account is in `moves`.
  ASSERT_EQ(j.at("moves").size(), 1u);
  const auto& m = j.at("moves").at(0);
  for (const char* key :
       {"axis", "position_rad", "error_rad", "on_target", "steps", "stop_cause", "target_rad"}) {
    EXPECT_TRUE(m.contains(key)) << key;
    EXPECT_FALSE(j.contains(key) && std::string(key) != "on_target" &&
                 std::string(key) != "stop_cause")
        << key << ": no top-level copy of the first axis";
  }
  EXPECT_EQ(m.at("axis"), "rotor");
  EXPECT_TRUE(j.at("on_target").get<bool>());
  EXPECT_EQ(j.at("stop_cause"), "on_target");
  EXPECT_NEAR(m.at("position_rad").get<double>(), -0.002, 25e-6);
  // The log holds the move's account and the controller's state per drive cycle.
  const auto logged =
      run_command("/usr/bin/python3 -c \"import h5py, json; f = h5py.File('" +
                  (dir / "move" / "run.h5").string() +
                  "'); m = json.loads(f['axes/rotor'].attrs['summary'])['move']; s = "
                  "f['axes/rotor/drive/move_state'][:]; "
                  "print(m['target_rad'], m['stop_cause'], int(s.max()), int(s[0]))\"");
  EXPECT_EQ(logged.out, "-0.002 on_target 5 1\n") << logged.err;

  const auto bad = run_command(kPiezo + " move --to 0.001 --tolerance 0 --config " + kSimConfig +
                               " --out " + (dir / "bad").string());
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("--tolerance"), std::string::npos) << bad.err;
  EXPECT_NE(bad.err.find("allowed: (0, 0.1] rad"), std::string::npos) << bad.err;
  EXPECT_FALSE(fs::exists(dir / "bad"));
}

// A script's moves follow each other within a second: each gets a run
// directory of its own (before, the second failed: "exists and is not an
// empty directory"). A move that runs out of time says so in its log as in
// its JSON and exit code (before, the log said completed/completed).
TEST(RunCli, MovesInOneSecondGetTheirOwnDirsAndATimeoutIsLoggedAsOne) {
  const auto dir = fresh_temp_dir("move-dirs");
  const std::string move = "cd " + dir.string() + " && " + kPiezo + " move --config " + kSimConfig +
                           " --set run.clock=virtual --json";
  std::set<std::string> run_dirs;
  for (int i = 0; i < 3; ++i) {
    const auto r = run_command(move + " --to 0.0005");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    run_dirs.insert(nlohmann::json::parse(r.out).at("run_dir").get<std::string>());
  }
  EXPECT_EQ(run_dirs.size(), 3u);
  const auto late = run_command(move + " --to 0.5 --timeout 0.3");
  EXPECT_EQ(late.exit_code, 1) << late.err;
  const auto j = nlohmann::json::parse(late.out);
  EXPECT_EQ(j.at("stop_cause"), "timeout");
  const auto logged =
      run_command("/usr/bin/python3 -c \"import h5py; f = h5py.File('" +
                  (dir / j.at("log").get<std::string>()).string() +
                  "'); a = f.attrs; print(a['status'].decode(), a['stop_cause'].decode())\"");
  EXPECT_EQ(logged.out, "failed timeout\n") << logged.err;
  fs::remove_all(dir);
}

// The log's layout for long experiments: the codes as uint8, every column
// shuffled and deflated, as h5py sees it.
TEST(RunCli, TheLogStoresCodesAsBytesAndCompressesEveryColumn) {
  const auto dir = fresh_temp_dir("log-layout");
  const auto r =
      run_command(kPiezo + " run --config " + kSimConfig +
                  " --set run.clock=virtual --duration 0.5 --out " + (dir / "r").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto check = run_command(
      "/usr/bin/python3 -c \"import h5py; f = h5py.File('" + (dir / "r" / "run.h5").string() +
      "'); d = []; f.visititems(lambda n, o: d.append(o) if isinstance(o, h5py.Dataset) and "
      "o.chunks else None); print(len(d), all(o.compression == 'gzip' and o.shuffle for o in d), "
      "f['axes/rotor/drive/phase'].dtype, f['axes/rotor/sensor/status'].dtype, "
      "f['axes/rotor/drive/t'].dtype, "
      "f['axes/rotor/drive/V'].dtype)\"");
  // drive 6, sensor 6, observer 8, a scan's triggers 6 (empty here), timing 2
  // (written whole: not chunked, not counted).
  EXPECT_EQ(check.out, "26 True uint8 uint8 float64 float64\n") << check.err;
}

// An --out that cannot be created is bad input: exit 2 before the rig is set up.
TEST(RunCli, AnUnwritableOutIsRefusedBeforeAnything) {
  const auto r = run_command(kPiezo + " run --config " + kSimConfig + " --out /proc/piezo-run");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("--out: /proc/piezo-run: cannot be created in /proc"), std::string::npos)
      << r.err;
}

// A log that cannot grow (a file-size limit) on the virtual clock: the
// drive stops, nothing hangs (the loops no longer wait for a host that has
// stopped draining), the process exits 1 naming the cause, and the log is
// closed, marked failed and readable.
TEST(RunCli, AFullDiskOnTheVirtualClockStopsTheRunWithExit1) {
  const auto dir = fresh_temp_dir("run-full-disk");
  const fs::path script = dir / "full-disk.sh";
  write_file(
      script,
      "ulimit -f 6000\n" + kPiezo + " run --config " + kSimConfig +
          " --set run.clock=virtual --set run.flush_interval_s=1 --duration 120 --json --out " +
          (dir / "run").string() + "\n");
  const auto r = run_command("timeout 120 bash " + script.string());
  ASSERT_EQ(r.exit_code, 1) << "124 would be a hang: " << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("stop_cause"), "log_failed");
  EXPECT_EQ(j.at("output").at("state"), "confirmed");
  EXPECT_LT(j.at("t_end_s").get<double>(), 120.0);
  const auto check =
      h5py_check(dir / "run" / "run.h5",
                 "print(f.attrs['status'].decode(), len(f['axes/rotor/drive/V']) > 0)\n");
  EXPECT_EQ(check.out, "failed True\n") << check.err;
}

TEST(RunCli, SigintRampsDownClosesTheLogInterruptedAndExits130) {
  const auto dir = fresh_temp_dir("run-sigint");
  const auto out = dir / "run";
  Spawned run({kPiezo, "run", "--config", kSimConfig, "--set", "run.clock=virtual", "--duration",
               "100000", "--out", out.string()},
              (dir / "output.txt").string());
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  run.signal(SIGINT);
  EXPECT_EQ(run.wait_exit(), 130);
  const auto check = h5py_check(out / "run.h5", R"(
assert f.attrs['status'].decode() == 'interrupted', f.attrs['status']
assert f['axes/rotor/drive/V'][-1] == 0.0
assert f['axes/rotor/drive/phase'][-1] == 2  # stopped
assert len(f['axes/rotor/sensor/theta']) > 100
print('ok')
)");
  EXPECT_EQ(check.out, "ok\n") << check.err;
}

// kill -9 leaves no chance to close the file: what was flushed reads as it
// is, or (killed inside a flush) once `piezo recover` has rebuilt it.
TEST(RunCli, KillNineLeavesAReadableLogMissingAtMostTheLastSecond) {
  const auto dir = fresh_temp_dir("run-kill9");
  const auto out = dir / "run";
  Spawned run({kPiezo, "run", "--config", kSimConfig, "--duration", "60", "--out", out.string()},
              (dir / "output.txt").string());
  // Wait until the run has started (the log exists), then let it run 2.5 s.
  for (int i = 0; i < 200 && !fs::exists(out / "run.h5"); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_TRUE(fs::exists(out / "run.h5"));
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));
  run.signal(SIGKILL);
  EXPECT_EQ(run.wait_exit(), 128 + SIGKILL);
  // What the run showed it had reached, on its last progress line (one a
  // second): a loaded machine runs behind the wall clock, so that, not the
  // time the run was alive, is what the log must hold to within a second.
  double shown_t = 0;
  {
    std::ifstream output(dir / "output.txt");
    std::string line;
    while (std::getline(output, line)) {
      double t = 0;
      if (std::sscanf(line.c_str(), "t %lf/", &t) == 1) shown_t = t;
    }
  }
  const std::string facts_of_log = R"(
assert f.attrs['status'].decode() in ('incomplete', 'recovered'), f.attrs['status']
t = f['axes/rotor/drive/t'][:]
print(len(t), t[-1] if len(t) else -1, len(f['axes/rotor/sensor/t'][:]))
)";
  auto check = h5py_check(out / "run.h5", facts_of_log);
  if (check.exit_code != 0) {
    // Killed inside HDF5's own flush, whose metadata it leaves half-written
    // (a few percent of instants): the journal beside it rebuilds it.
    const auto recovered = run_command(kPiezo + " recover " + out.string());
    ASSERT_EQ(recovered.exit_code, 0) << check.err << recovered.err;
    check = h5py_check(out / "run.h5", facts_of_log);
  }
  ASSERT_EQ(check.exit_code, 0) << check.err;
  std::istringstream facts(check.out);
  long drive_samples = 0, sensor_samples = 0;
  double last_t = 0;
  facts >> drive_samples >> last_t >> sensor_samples;
  EXPECT_GT(shown_t, 0.0) << "no progress line in 2.5 s";
  EXPECT_GE(last_t, shown_t - 1.0) << check.out;
  EXPECT_GT(sensor_samples, 0);
}

}  // namespace
}  // namespace piezo::testing
