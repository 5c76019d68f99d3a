#pragma once
// A run's session with its board, whoever asks for it (`piezo run`, `step`,
// `move`, `calibrate`: run_command.cpp keeps their options and printing):
// the board connected and every check made before anything is created, the
// run's directory and its log's header, the drive followed into the log, and
// the log's end.

#include <atomic>
#include <filesystem>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "config/config_file.hpp"
#include "io/log_schema.hpp"
#include "io/run_log.hpp"
#include "run/board_client.hpp"
#include "run/board_request.hpp"
#include "run/board_run.hpp"
#include "run/local_board.hpp"
#include "run/run_session.hpp"

namespace piezo::host {

/// What drives: piezod at an address, or the firmware in this process
/// (reached through the protocol all the same, until the report is done).
struct RunBoard {
  std::unique_ptr<LocalBoard> local;  ///< declared first: its context outlives the client
  std::optional<BoardClient> client;
  protocol::Hello hello;
  protocol::AxisInfo axis;              ///< the axis the run drives (a group's first)
  nlohmann::json dictionary;            ///< the board's `describe`: its commands and limits
  std::optional<BoardRequest> request;  ///< what this run asks of it, checked and prepared
  std::string geometry_note;            ///< the board's sensor radius differed from the config's
  /// The run's axes in the board's order, one or several (a group move's
  /// targets, else the one axis it drives): the log keeps each under its
  /// group, the view plots each.
  std::vector<std::string> axes;
};

/// Connects to the board (`config`'s [rig] address, or one in this process),
/// reads its hello and dictionary, resolves the run's axes once (a group
/// move's targets, else the one axis [rig] axis names), refuses a target
/// outside its axis's travel window, and checks and prepares the request:
/// every refusal comes before anything is created.
void connect(RunBoard& board, const config::ConfigFile& config, const RunAsked& asked);

/// The run's directory and log, once everything is checked: only now does
/// the run leave traces (config.toml, run.h5 with its header, every axis
/// under its group).
[[nodiscard]] RunLog create_log(const std::filesystem::path& dir, const config::ConfigFile& config,
                                const RunBoard& board, const std::string& utc_start);

/// Runs it until the board's account of its end (`stop`: the run's stop
/// request; `on_rows`: each flush's rows, for a live view); a failure before
/// the run's end leaves the log marked failed with the reason (the log keeps
/// what it has) and is thrown on.
[[nodiscard]] RunSummary drive(RunBoard& board, const config::ConfigFile& config, RunLog& log,
                               const std::atomic<bool>& stop,
                               const std::function<void(const LiveStatus&)>& status_line,
                               const std::atomic<bool>& estop_requested,
                               const std::function<void(const log_schema::AxesRows&)>& on_rows,
                               AxisStops& axis_stops);

/// Writes the end of the log: results (`result`, the run's JSON, each axis's
/// on its group), then the final status. A log that cannot be finished fails
/// the run; what was flushed stays readable.
void finish_log(RunLog& log, RunSummary& summary, const nlohmann::json& result);

}  // namespace piezo::host
