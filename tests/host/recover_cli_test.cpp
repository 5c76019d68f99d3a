// `piezo recover` on what a crash, a full disk or a bad sector leaves: a run
// killed mid-way, then its journal torn or its log's bytes flipped. Recovery
// never keeps fewer samples than the run directory held, never calls a
// log it cannot read whole "readable", and says so (exit 1) when it keeps
// less than it found. The logs are read back with h5py.

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>
#include <tuple>

#include "../support/run_command.hpp"
#include "../support/spawn.hpp"
#include "build_paths.hpp"

namespace piezo::testing {
namespace {

namespace fs = std::filesystem;
const std::string kPiezo = build_paths::piezo;
const std::string kSimConfig = std::string(build_paths::source_dir) + "/configs/sim.toml";

/// Rows of drive/t and sensor/t as h5py reads them, or -1 when it cannot
/// read every dataset of the log whole. File locking off: the check may
/// read a log whose writer is stopped, not yet killed.
std::pair<long, long> h5py_rows(const fs::path& log) {
  const fs::path script = log.parent_path().parent_path() / "rows.py";
  write_file(script, R"(import h5py, sys
try:
    f = h5py.File(sys.argv[1], 'r')
    def read_all(name, obj):
        if isinstance(obj, h5py.Dataset):
            obj[:]
    f.visititems(read_all)
    print(len(f['axes/rotor/drive/t']), len(f['axes/rotor/sensor/t']))
except Exception as e:
    print(-1, -1)
)");
  const auto r = run_command("HDF5_USE_FILE_LOCKING=FALSE /usr/bin/python3 " + script.string() +
                             " " + log.string());
  std::istringstream in(r.out);
  long drive = -1, sensor = -1;
  in >> drive >> sensor;
  return {drive, sensor};
}

/// Whether every thread of `pid` has stopped (SIGSTOP takes effect when
/// each thread next leaves the kernel, not when kill() returns).
bool all_threads_stopped(pid_t pid) {
  const fs::path tasks = fs::path("/proc") / std::to_string(pid) / "task";
  std::error_code ec;
  for (const auto& task : fs::directory_iterator(tasks, ec)) {
    std::ifstream stat(task.path() / "stat");
    std::string line;
    std::getline(stat, line);
    const auto state = line.find(") ");  // the state follows the command's closing parenthesis
    if (state == std::string::npos || (line[state + 2] != 'T' && line[state + 2] != 't')) {
      return false;
    }
  }
  return !ec;
}

/// A real-time run of the simulated rig killed -9 mid-way, as in a crash:
/// run.h5 up to its last flush and run.journal beside it, the log reading
/// whole with at least `min_rows` drive rows.
///
/// A kill that lands while HDF5 writes a flush (the chunks, then the
/// metadata that points at them) leaves a log h5py cannot read, which the
/// journal design allows and recovery repairs (the kill test covers it).
/// Under AddressSanitizer a flush takes longer (HDF5's allocations go
/// through its allocator): 2 to 4 kills in 20 landed there, against 1 in
/// 20 in the optimised build, and a test that needed a whole log after a
/// kill at a fixed instant failed when its attempts all landed there. So
/// the run is stopped first (SIGSTOP) and its log read: a stopped process
/// writes nothing, so a kill then leaves the log as it was read. A log
/// that does not read whole is killed all the same and a new run tried,
/// a little later into it: a run continued after a stop has missed its
/// deadlines, and its supervisor may end it (and remove its journal).
fs::path killed_run(const fs::path& dir, long min_rows) {
  for (int attempt = 0;; ++attempt) {
    const auto out = dir / ("kill" + std::to_string(attempt)) / "killed";
    Spawned run({kPiezo, "run", "--config", kSimConfig, "--duration", "5", "--out", out.string()},
                (out.parent_path() / "output.txt").string());
    for (int i = 0; i < 200 && !fs::exists(out / "run.h5"); ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1600 + 97 * (attempt % 7)));
    run.signal(SIGSTOP);
    while (!all_threads_stopped(run.pid()) && !run.exited()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    const bool whole = !run.exited() && fs::exists(out / "run.journal") &&
                       h5py_rows(out / "run.h5").first >= min_rows;
    run.signal(SIGKILL);
    run.wait_exit();
    if (whole || attempt == 9) return out;
  }
}

fs::path copy_of(const fs::path& run, const fs::path& where) {
  fs::remove_all(where);
  fs::create_directories(where.parent_path());
  fs::copy(run, where, fs::copy_options::recursive);
  return where;
}

void truncate_to(const fs::path& file, std::uintmax_t bytes) {
  fs::resize_file(file, std::min(bytes, fs::file_size(file)));
}

void flip_byte(const fs::path& file, std::uintmax_t at) {
  std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
  f.seekg(static_cast<std::streamoff>(at));
  char c = 0;
  f.get(c);
  f.seekp(static_cast<std::streamoff>(at));
  f.put(static_cast<char>(c ^ 0x5a));
}

nlohmann::json recover(const fs::path& run, int& exit_code) {
  const auto r = run_command(kPiezo + " recover " + run.string() + " --json");
  exit_code = r.exit_code;
  return r.out.empty() ? nlohmann::json{} : nlohmann::json::parse(r.out);
}

// Each damage the journal can take (torn at any length, a flipped byte):
// the recovered log holds as many samples as the larger of the two copies,
// run.h5 as the crash left it and the journal on its own.
TEST(RecoverCli, ATornJournalNeverReplacesALongerLogWithLess) {
  const auto dir = fresh_temp_dir("recover-torn");
  const fs::path run = killed_run(dir, 1001);
  ASSERT_TRUE(fs::exists(run / "run.journal"));
  const auto [log_drive, log_sensor] = h5py_rows(run / "run.h5");
  ASSERT_GT(log_drive, 1000) << "the killed run's log holds its flushed samples";
  const std::uintmax_t journal_bytes = fs::file_size(run / "run.journal");

  struct Damage {
    std::string name;
    std::function<void(const fs::path&)> apply;
  };
  std::vector<Damage> damages;
  for (std::uintmax_t bytes : {std::uintmax_t{30'000}, std::uintmax_t{100}, journal_bytes / 4,
                               journal_bytes / 2, journal_bytes * 9 / 10, journal_bytes - 1}) {
    damages.push_back({"torn at " + std::to_string(bytes),
                       [bytes](const fs::path& j) { truncate_to(j, bytes); }});
  }
  for (std::uintmax_t at : {std::uintmax_t{20}, journal_bytes / 3, journal_bytes * 2 / 3}) {
    damages.push_back(
        {"byte flipped at " + std::to_string(at), [at](const fs::path& j) { flip_byte(j, at); }});
  }
  int variant = 0;
  for (const auto& damage : damages) {
    SCOPED_TRACE(damage.name);
    const fs::path both = copy_of(run, dir / ("v" + std::to_string(variant)) / "run");
    damage.apply(both / "run.journal");
    // The journal alone: what it would give without run.h5.
    const fs::path alone = copy_of(both, dir / ("j" + std::to_string(variant++)) / "run");
    fs::remove(alone / "run.h5");
    int alone_exit = 0;
    const auto journal_only = recover(alone, alone_exit);
    const long journal_drive =
        journal_only.is_null() ? 0 : journal_only.at("drive_samples").get<long>();

    int exit_code = 0;
    const auto j = recover(both, exit_code);
    EXPECT_EQ(exit_code, 0) << j;
    EXPECT_EQ(j.at("drive_samples").get<long>(), std::max(log_drive, journal_drive)) << j;
    EXPECT_GE(j.at("sensor_samples").get<long>(), log_sensor) << j;
    const auto [kept_drive, kept_sensor] = h5py_rows(both / "run.h5");
    EXPECT_EQ(kept_drive, j.at("drive_samples").get<long>());
    EXPECT_EQ(kept_sensor, j.at("sensor_samples").get<long>());
    const auto report = run_command(kPiezo + " report " + both.string() + " --json");
    EXPECT_EQ(report.exit_code, 0) << report.err;
  }
}

// A kill inside HDF5's flush can leave observer/t grown over a chunk never
// written (read back as fill values) and the group's other columns not yet
// grown: the journal, written first, holds those rows whole. Recovery takes
// them from it, whatever the log's last values read as.
TEST(RecoverCli, FillValuesAtTheLogsEndDoNotDisownTheJournal) {
  const auto dir = fresh_temp_dir("recover-fill");
  const fs::path script = dir / "tear.py";
  write_file(script, R"(import h5py, sys
src, dst = sys.argv[1], sys.argv[2]
with h5py.File(src, 'r') as f, h5py.File(dst, 'w') as g:
    for k, v in f.attrs.items():
        g.attrs[k] = v
    def copy(name, obj):
        if not isinstance(obj, h5py.Dataset):
            return
        data = obj[:]
        if name == 'axes/rotor/observer/t':
            data[-1] = 0.0
        elif name.startswith('axes/rotor/observer/'):
            data = data[:0]
        g.create_dataset(name, data=data, maxshape=(None,), chunks=(4096,))
    f.visititems(copy)
    print(len(f['axes/rotor/observer/t']))
)");
  // The torn copy is made from a killed log that reads whole (killed_run).
  const fs::path run = killed_run(dir, 1001);
  ASSERT_TRUE(fs::exists(run / "run.journal"));
  const CommandResult torn =
      run_command("/usr/bin/python3 " + script.string() + " " + (run / "run.h5").string() + " " +
                  (run / "torn.h5").string());
  ASSERT_EQ(torn.exit_code, 0) << torn.err;
  ASSERT_GT(std::stol(torn.out), 10) << "the run was killed before its first observer rows";
  fs::rename(run / "torn.h5", run / "run.h5");

  int exit_code = 0;
  const auto j = recover(run, exit_code);
  EXPECT_EQ(exit_code, 0) << j;
  EXPECT_TRUE(j.value("losses", nlohmann::json::array()).empty()) << j;
  const fs::path check = dir / "check.py";
  write_file(check, R"(import h5py, sys, numpy as np
with h5py.File(sys.argv[1], 'r') as f:
    t = f['axes/rotor/observer/t'][:]
    bad = int(np.sum(~np.isfinite(f['axes/rotor/observer/x_hat'][:])))
    print(len(t), bool(np.all(np.diff(t) > 0)), bad)
)");
  const auto r =
      run_command("/usr/bin/python3 " + check.string() + " " + (run / "run.h5").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::istringstream in(r.out);
  long rows = 0, lost = -1;
  std::string increasing;
  in >> rows >> increasing >> lost;
  EXPECT_GE(rows, std::stol(torn.out));
  EXPECT_EQ(increasing, "True") << "observer/t keeps the fill value instead of the journal's time";
  EXPECT_EQ(lost, 0);
}

// A flip in a group's name heap (the list of its members' names). Where
// the datasets still read by their paths, only a walk of the file, as
// h5py's visititems takes it, fails: recover walks it too. Each damaged
// log is rebuilt from what reads, says when that is less, and every
// reader takes it afterwards.
TEST(RecoverCli, ADamagedGroupIsFoundThoughEveryDatasetReads) {
  const auto dir = fresh_temp_dir("recover-heap");
  const auto run = dir / "done";
  const auto done = run_command(kPiezo + " run --config " + kSimConfig +
                                " --set run.clock=virtual --duration 1 --out " + run.string());
  ASSERT_EQ(done.exit_code, 0) << done.err;
  const auto [drive, sensor] = h5py_rows(run / "run.h5");
  ASSERT_GT(drive, 0);
  std::ifstream in(run / "run.h5", std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // A local heap: "HEAP", version and reserved (4), its data's size (8),
  // then the offset of its free list, whose low byte is flipped.
  int heaps = 0, unwalkable = 0;
  for (auto at = bytes.find("HEAP"); at != std::string::npos; at = bytes.find("HEAP", at + 1)) {
    SCOPED_TRACE("heap at " + std::to_string(at));
    ++heaps;
    const fs::path damaged = copy_of(run, dir / ("h" + std::to_string(heaps)) / "run");
    flip_byte(damaged / "run.h5", at + 16);
    if (h5py_rows(damaged / "run.h5").first >= 0) continue;  // a heap h5py's walk does not read
    ++unwalkable;
    int exit_code = -1;
    const auto j = recover(damaged, exit_code);
    ASSERT_FALSE(j.empty()) << "recover said nothing";
    EXPECT_TRUE(j.at("rebuilt").get<bool>()) << j;
    EXPECT_EQ(exit_code, j.at("kept_less").get<bool>() ? 1 : 0) << j;
    EXPECT_EQ(h5py_rows(damaged / "run.h5"), std::make_pair(j.at("drive_samples").get<long>(),
                                                            j.at("sensor_samples").get<long>()));
  }
  EXPECT_GT(unwalkable, 0) << heaps << " heaps, none that h5py's walk fails on";
}

// A completed log with bytes flipped in its samples: recover reads every
// dataset before it calls the log readable. Where it cannot, it rebuilds
// the log from what reads (the old file kept), and when that is less than
// the file claimed it says so and exits 1; afterwards every reader works.
TEST(RecoverCli, AFlippedByteIsFoundAndWhatIsLostIsSaid) {
  const auto dir = fresh_temp_dir("recover-flipped");
  const auto run = dir / "done";
  const auto done = run_command(kPiezo + " run --config " + kSimConfig +
                                " --set run.clock=virtual --duration 2 --out " + run.string());
  ASSERT_EQ(done.exit_code, 0) << done.err;
  const auto [drive, sensor] = h5py_rows(run / "run.h5");
  ASSERT_GT(drive, 10'000);
  const std::uintmax_t size = fs::file_size(run / "run.h5");
  int found_damage = 0;
  for (int k = 1; k <= 11; ++k) {
    const std::uintmax_t at = size * k / 12;
    SCOPED_TRACE("byte flipped at " + std::to_string(at));
    const fs::path damaged = copy_of(run, dir / ("f" + std::to_string(k)) / "run");
    flip_byte(damaged / "run.h5", at);
    const bool readable_before = h5py_rows(damaged / "run.h5").first >= 0;
    int exit_code = 0;
    const auto r = run_command(kPiezo + " recover " + damaged.string() + " --json");
    exit_code = r.exit_code;
    if (!readable_before) ++found_damage;
    if (readable_before) {
      // A flip in slack space or an attribute's padding: the samples all read.
      EXPECT_EQ(exit_code, 0) << r.out << r.err;
      continue;
    }
    if (r.out.empty()) {
      // Not even HDF5's superblock opens: said so, and nothing is touched.
      EXPECT_NE(exit_code, 0);
      EXPECT_NE(r.err.find("run.h5"), std::string::npos) << r.err;
      EXPECT_TRUE(fs::exists(damaged / "run.h5"));
      continue;
    }
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_TRUE(j.at("rebuilt").get<bool>()) << j;
    EXPECT_NE(j.at("status"), "completed") << j;
    EXPECT_TRUE(fs::exists(damaged / "run.h5.damaged"));
    const bool less = j.at("drive_samples").get<long>() < drive ||
                      j.at("sensor_samples").get<long>() < sensor || !j.at("losses").empty();
    EXPECT_EQ(j.at("kept_less").get<bool>(), less) << j;
    EXPECT_EQ(exit_code, less ? 1 : 0) << j;
    if (less) {
      EXPECT_NE(r.err.find("not recovered"), std::string::npos) << r.err;
    }
    const auto [kept_drive, kept_sensor] = h5py_rows(damaged / "run.h5");
    EXPECT_EQ(kept_drive, j.at("drive_samples").get<long>());
    EXPECT_EQ(kept_sensor, j.at("sensor_samples").get<long>());
    // Every reader reads it now: a report, or a refusal naming what is
    // missing (a column lost whole), never HDF5 failing under it.
    const auto report = run_command(kPiezo + " report " + damaged.string() + " --json");
    if (report.exit_code != 0) {
      EXPECT_EQ(report.exit_code, 2) << report.err;
      EXPECT_EQ(report.err.find("HDF5"), std::string::npos) << report.err;
    }
  }
  // Most of a log's bytes are its compressed samples: most flips land there.
  EXPECT_GE(found_damage, 5);
}

}  // namespace
}  // namespace piezo::testing
