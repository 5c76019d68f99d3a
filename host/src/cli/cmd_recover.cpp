// piezo recover RUN_DIR: makes a crashed run's log whole again from its
// journal (run_journal.hpp). piezo recover --spill FILE --out DIR: a log
// from the board's spill file, which a crashed piezod keeps as
// SPILL.previous when it starts again (spill_file.hpp).

#include <fmt/format.h>

#include <algorithm>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "commands.hpp"
#include "config/config_file.hpp"
#include "io/log_schema.hpp"
#include "io/run_log.hpp"
#include "io/run_recovery.hpp"
#include "piezo/config/config_error.hpp"
#include "piezo/protocol/error.hpp"
#include "piezo/protocol/frame.hpp"
#include "run/sample_collector.hpp"

namespace piezo::host {
namespace {

struct RecoverOptions {
  std::string run_dir;
  std::string spill;   ///< a piezod spill file instead of a run directory
  std::string config;  ///< the rig's config, for the sensor's r2
  bool json = false;
};

/// The samples of a spill file ([u32 little-endian length][frame]...), up
/// to a torn or damaged frame, as a run log in `dir` marked recovered.
int recover_spill(const RecoverOptions& o) {
  namespace fs = std::filesystem;
  if (o.run_dir.empty()) throw config::ConfigError("--out", "", "required with --spill");
  if (fs::exists(fs::path(o.run_dir) / "run.h5")) {
    throw config::ConfigError("--out", o.run_dir, "holds a run.h5 already");
  }
  // The board's axes, in its order (its records carry the index): the
  // config's, or the one default axis.
  const config::BoardConfig board =
      o.config.empty() ? config::BoardConfig{}
                       : config::load_config_file(o.config, {}, config::ConfigScope::sensor).board;
  std::ifstream in(o.spill, std::ios::binary);
  if (!in) throw config::ConfigError(o.spill, "file", "cannot be read");
  std::vector<firmware::DriveSample> drive;
  std::vector<firmware::SensorSample> sensor;
  std::size_t frames = 0;
  std::string frame;
  for (unsigned char length[4]; in.read(reinterpret_cast<char*>(length), 4); ++frames) {
    const std::uint32_t n =
        length[0] | length[1] << 8 | length[2] << 16 | static_cast<std::uint32_t>(length[3]) << 24;
    frame.resize(n);
    if (n > (64u << 20) || !in.read(frame.data(), n)) break;  // torn at the crash
    try {
      const auto header = protocol::decode_header(frame);
      if (header.stream == protocol::Stream::drive) {
        const auto s = protocol::decode_drive(frame);
        drive.insert(drive.end(), s.begin(), s.end());
      } else {
        const auto s = protocol::decode_sensor(frame);
        sensor.insert(sensor.end(), s.begin(), s.end());
      }
    } catch (const protocol::ProtocolError&) {
      break;
    }
  }
  if (drive.empty()) throw config::ConfigError(o.spill, "drive", "no drive samples in the file");
  fs::create_directories(o.run_dir);
  // Each axis that has drive records: its own collector, its own group.
  std::vector<std::string> names;
  std::vector<std::size_t> board_index;
  for (std::size_t i = 0; i < board.axes.size(); ++i) {
    if (std::any_of(drive.begin(), drive.end(), [i](const auto& s) { return s.axis == i; })) {
      names.push_back(board.axes[i].name);
      board_index.push_back(i);
    }
  }
  if (names.empty()) {
    throw config::ConfigError(
        o.spill, "axis",
        fmt::format("no drive samples of the config's axes ({} of them)", board.axes.size()));
  }
  std::deque<SampleCollector> collectors;
  for (const std::size_t i : board_index)
    collectors.emplace_back(drive.front().t, board.axes[i].sensor.r2_m, nullptr);
  const auto collector_of = [&](std::uint8_t axis) -> SampleCollector* {
    const auto it = std::find(board_index.begin(), board_index.end(), axis);
    return it == board_index.end() ? nullptr : &collectors[it - board_index.begin()];
  };
  for (const auto& s : drive)
    if (SampleCollector* c = collector_of(s.axis)) c->add(s);
  for (const auto& s : sensor)
    if (SampleCollector* c = collector_of(s.axis)) c->add(s);
  const std::string log_path = (fs::path(o.run_dir) / "run.h5").string();
  RunLog log = RunLog::create(
      log_path,
      {{log_schema::kRecoveredFrom,
        fmt::format("piezod spill file {}: {} frames", o.spill, frames)},
       {log_schema::kTimeOrigin, "seconds from the first drive sample in the spill file"}},
      names);
  log_schema::AxesRows rows;
  for (std::size_t i = 0; i < names.size(); ++i) {
    log.set_axis_attribute(i, log_schema::kTheta,
                           fmt::format("(displacement - first good displacement) / {} m",
                                       board.axes[board_index[i]].sensor.r2_m));
    rows.push_back(std::move(collectors[i].rows()));
  }
  log.append(rows);
  log.close("recovered");
  if (o.json) {
    std::cout << nlohmann::json{{"run_dir", o.run_dir},
                                {"rebuilt", true},
                                {"status", "recovered"},
                                {"drive_samples", drive.size()},
                                {"sensor_samples", sensor.size()},
                                {"frames", frames}}
                     .dump()
              << "\n";
  } else {
    fmt::print(
        "{}: run.h5 from the spill file {} ({} frames, {} drive, {} sensor samples), "
        "marked recovered\n",
        o.run_dir, o.spill, frames, drive.size(), sensor.size());
  }
  return 0;
}

int run(const RecoverOptions& o) {
  if (!o.spill.empty()) return recover_spill(o);
  const Recovery r = recover_run(o.run_dir);
  if (o.json) {
    std::cout << nlohmann::json{{"run_dir", o.run_dir},
                                {"rebuilt", r.rebuilt},
                                {"status", r.status},
                                {"drive_samples", r.drive_rows},
                                {"sensor_samples", r.sensor_rows},
                                {"observer_samples", r.observer_rows},
                                {"trigger_pulses", r.trigger_rows},
                                {"journal_blocks", r.blocks},
                                {"torn_bytes", r.torn_bytes},
                                {"damaged", r.damaged},
                                {"kept_less", r.kept_less()},
                                {"losses", r.losses}}
                     .dump()
              << "\n";
  } else if (r.rebuilt) {
    fmt::print(
        "{}: run.h5 rebuilt from what run.h5 and run.journal held ({} blocks, {} drive, {} "
        "sensor samples{}), marked recovered{}\n",
        o.run_dir, r.blocks, r.drive_rows, r.sensor_rows,
        r.torn_bytes > 0 ? fmt::format("; {} torn bytes at the journal's end dropped", r.torn_bytes)
                         : std::string(),
        r.damaged.empty() ? std::string() : "; the old file kept as run.h5.damaged");
  } else {
    fmt::print("{}: run.h5 is readable ({}); nothing to recover\n", o.run_dir, r.status);
  }
  // Less than was found: said on stderr and in the exit code, whatever the format.
  for (const std::string& loss : r.losses)
    fmt::print(stderr, "{}: not recovered: {}\n", o.run_dir, loss);
  return r.kept_less() ? 1 : 0;
}

}  // namespace

void add_recover_command(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<RecoverOptions>();
  CLI::App* cmd = app.add_subcommand(
      "recover", "Rebuild a crashed run's run.h5 from its journal, marked recovered");
  cmd->add_option("RUN_DIR", o->run_dir,
                  "Run directory (holds run.h5 and run.journal); with --spill, the new run's")
      ->required();
  cmd->add_option("--spill", o->spill,
                  "A piezod spill file (SPILL.previous after a crash): write its samples as a "
                  "run log in RUN_DIR")
      ->check(CLI::ExistingFile);
  add_config_option(*cmd, o->config, "With --spill: the rig's config, for the sensor's r2")
      ->check(CLI::ExistingFile);
  add_json_flag(*cmd, o->json);
  commands.add(cmd, [o] { return run(*o); });
}

}  // namespace piezo::host
