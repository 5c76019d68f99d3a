// A run's session with its board (run_setup.hpp): connected and checked
// before anything is created, its log's header, its drive, its log's end.

#include "run_setup.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>

#include "config/effective_config.hpp"
#include "config/rig.hpp"
#include "io/log_schema.hpp"
#include "io/parameters_json.hpp"
#include "piezo/config/config_error.hpp"
#include "piezo/firmware/wire_keys.hpp"
#include "run/board_run.hpp"

namespace piezo::host {

namespace fs = std::filesystem;

namespace {

std::string host_name() {
  char buf[256] = {};
  gethostname(buf, sizeof buf - 1);
  return buf;
}

/// The run's axes in the board's order: a group move's targets (each must
/// be the board's), else the one axis `named` names (resolved once).
std::vector<std::string> run_axes(const RunAsked& asked, const protocol::Hello& hello,
                                  const std::string& named, const std::string& address) {
  // A group's axes by name: a move's targets, a scan's scans.
  std::vector<std::string> group;
  std::string_view group_key = wire_key::targets;
  if (const auto* move = std::get_if<asked::Move>(&asked)) {
    for (const auto& [axis, target] : move->targets) group.push_back(axis);
  }
  if (const auto* scan = std::get_if<asked::Scan>(&asked)) {
    group_key = wire_key::scans;
    // A scan of no axis named is the config's [rig] axis's.
    for (const auto& [axis, one] : scan->scans)
      group.push_back(axis.empty() ? axis_info(hello, named, address).name : axis);
  }
  if (group.empty()) return {axis_info(hello, named, address).name};
  std::vector<std::string> names, out;
  for (const auto& a : hello.axes) names.push_back(a.name);
  for (const std::string& axis : group) {
    if (std::find(names.begin(), names.end(), axis) == names.end()) {
      throw config::ConfigError("piezod at " + address, fmt::format("{}.{}", group_key, axis),
                                fmt::format("\"{}\" is not an axis of the board (allowed: {})",
                                            axis, fmt::join(names, ", ")));
    }
  }
  for (const std::string& name : names)
    if (std::find(group.begin(), group.end(), name) != group.end()) out.push_back(name);
  return out;
}

/// Refuses a move's target beyond its axis's travel window as the board
/// declares it (hello), before anything is created: the board would refuse
/// it too, after the run's directory was made.
void check_travel(const RunAsked& asked, const protocol::Hello& hello, const std::string& axis,
                  const std::string& address) {
  const auto* move = std::get_if<asked::Move>(&asked);
  if (move == nullptr) return;
  std::map<std::string, double> targets = move->targets;
  if (targets.empty()) targets[axis] = move->target_rad;
  for (const auto& [name, target] : targets) {
    for (const protocol::AxisInfo& a : hello.axes) {
      if (a.name != (name.empty() ? axis_info(hello, name, address).name : name)) continue;
      const double lo = a.travel_min_rad.value_or(-INFINITY);
      const double hi = a.travel_max_rad.value_or(INFINITY);
      if (target >= lo && target <= hi) continue;
      throw config::ConfigError(
          "piezod at " + address,
          move->targets.empty() ? std::string(wire_key::target_rad)
                                : fmt::format("{}.{}", wire_key::targets, name),
          fmt::format("{:g} rad is outside axis {}'s travel window [{:g}, {:g}] rad (the board's "
                      "safety.travel_min_rad, travel_max_rad; nothing was sent)",
                      target, a.name, lo, hi));
    }
  }
}

}  // namespace

void connect(RunBoard& board, const config::ConfigFile& config, const RunAsked& asked) {
  if (config.host.board.address.empty()) {
    board.local = std::make_unique<LocalBoard>(config, config::build_rig(config.board));
    board.client.emplace(config::BoardAddress{board.local->address(), "", "", 0.0, ""},
                         board.local->context());
  } else {
    board.client.emplace(config.host.board);
  }
  board.hello = board.client->hello();
  board.axes = run_axes(asked, board.hello, config.host.board.axis, board.client->address());
  board.axis = axis_info(board.hello, board.axes.front(), board.client->address());
  check_travel(asked, board.hello, config.host.board.axis, board.client->address());
  if (const std::string note = sensor_geometry_note(config, board.axis); !note.empty()) {
    fmt::print(stderr, "piezo: {}\n", note);
    std::fflush(stderr);
    board.geometry_note = note;
  }
  board.dictionary = board.client->call("describe");
  board.request = board_request(config.host, asked);
  check_request(*board.request, board.dictionary, board.client->address());
  prepare_request(*board.request, *board.client);
}

RunLog create_log(const fs::path& dir, const config::ConfigFile& config, const RunBoard& board,
                  const std::string& utc_start) {
  fs::create_directories(dir);
  if (!fs::is_empty(dir)) {
    // Another run took the name between the check and now: never mix two.
    throw config::ConfigError("--out", dir.string(), "was taken by another run meanwhile");
  }
  std::ofstream(dir / "config.toml") << config::run_config_file(config);
  const bool remote = !board.local;
  const std::vector<std::string>& axes = board.axes;
  RunLog log = RunLog::create(
      (dir / "run.h5").string(),
      {{log_schema::kConfig, config.text},
       {log_schema::kConfigSource, config.source},
       {log_schema::kModelParameters, to_json(config.host.model).dump()},
       {log_schema::kPlantParameters,
        to_json(model::Parameters{config.host.model.drive, config.board.axis().plant}).dump()},
       {log_schema::kVersion, PIEZO_VERSION},
       {log_schema::kUtcStart, utc_start},
       {log_schema::kHost, host_name()},
       {log_schema::kClock, remote ? board.hello.clock : std::string(name(config.board.run.clock))},
       {log_schema::kDriveLatency, fmt::format("{:.9g}", board.hello.output_latency_s)},
       {log_schema::kTimeOrigin, "seconds from the run's start (first drive deadline)"}},
      axes);
  if (!board.geometry_note.empty())
    log.set_attribute(log_schema::kSensorGeometryNote, board.geometry_note);
  // Each axis its own angle's radius and model, on its group.
  for (std::size_t i = 0; i < axes.size(); ++i) {
    const protocol::AxisInfo& axis = axis_info(board.hello, axes[i], board.client->address());
    log.set_axis_attribute(
        i, log_schema::kTheta,
        fmt::format("(displacement - its zero: theta_zero_m, else its first good reading) / "
                    "sensor.r2_m, r2_m = {:.9g} m{}",
                    axis.r2_m, remote ? " (the board's, from its hello)" : ""));
    if (const config::AxisConfig* own = config.board.find_axis(axes[i])) {
      log.set_axis_attribute(i, log_schema::kModelParameters, to_json(own->model).dump());
      log.set_axis_attribute(i, log_schema::kPlantParameters,
                             to_json(model::Parameters{own->model.drive, own->plant}).dump());
    }
  }
  return log;
}

void finish_log(RunLog& log, RunSummary& summary, const nlohmann::json& result) {
  if (log.broken()) {
    log.abandon();  // a log that failed half-way is not written again
    return;
  }
  try {
    const auto histogram = [](const protocol::LoopHealth& h) {
      return h.timing ? h.timing->histogram_us : std::vector<double>{};
    };
    log.write(log_schema::kDrivePeriodErrorUs, histogram(summary.board.drive));
    log.write(log_schema::kAcquirePeriodErrorUs, histogram(summary.board.sensor));
    log.set_attribute(log_schema::kSummary, result.dump());
    log.set_attribute(log_schema::kRealtime,
                      fmt::format("{}", fmt::join(summary.board.realtime, "; ")));
    log.set_attribute(log_schema::kStopCause, summary.stop_cause());
    log.set_attribute(log_schema::kOutput, summary.output_state());
    // Each axis's own account on its group (an axis the run never measured has none).
    for (const nlohmann::json& axis : result.value(wire_key::axes, nlohmann::json::array())) {
      const auto i =
          std::find(log.axes().begin(), log.axes().end(), axis.value(wire_key::name, ""));
      if (i == log.axes().end()) continue;
      const auto index = static_cast<std::size_t>(i - log.axes().begin());
      log.set_axis_attribute(index, log_schema::kSummary, axis.dump());
      log.set_axis_attribute(index, log_schema::kStopCause,
                             axis.value(wire_key::stop_cause, "unknown"));
    }
    log.close(summary.status());
  } catch (const std::exception& e) {
    if (summary.host_error.empty()) summary.host_error = e.what();
    log.abandon();
  }
}

RunSummary drive(RunBoard& board, const config::ConfigFile& config, RunLog& log,
                 const std::atomic<bool>& stop,
                 const std::function<void(const LiveStatus&)>& status_line,
                 const std::atomic<bool>& estop_requested,
                 const std::function<void(const log_schema::AxesRows&)>& on_rows,
                 AxisStops& axis_stops) {
  try {
    RunSummary summary = run_on_board(config, *board.client, board.hello, log, stop, status_line,
                                      *board.request, &estop_requested, on_rows, &axis_stops);
    if (board.local && !log.broken()) {
      log.set_attribute(log_schema::kBoardEvents, board.local->events());
    }
    return summary;
  } catch (const std::exception& e) {
    if (!log.broken()) {
      try {
        log.set_attribute(log_schema::kStopCause, "host_error");
        log.set_attribute(log_schema::kError, e.what());
        log.close("failed");
      } catch (const std::exception&) {
        log.abandon();
      }
    }
    throw;
  }
}

}  // namespace piezo::host
