#pragma once
// One run on a built rig, the one-machine default: an in-process piezod
// serves the rig and the run goes through the protocol as a remote run
// does (run_on_board: the stream followed into the log, the live
// status, the summary at the end).

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "board_request.hpp"
#include "config/config_file.hpp"
#include "config/rig.hpp"
#include "io/run_log.hpp"
#include "observer_stage.hpp"
#include "piezo/protocol/messages.hpp"

namespace piezo::host {

/// What the host measured of one axis of a run.
struct AxisMeasured {
  std::string name;  ///< the board's axis ("" on a board that names none)
  /// Failed samples by HAL status, as the host counted them in the stream.
  std::map<std::string, std::uint64_t> drive_errors, sensor_errors;
  double theta_end_rad = 0.0;  ///< last good measured angle
  double t_end_s = 0.0;        ///< when it was measured
  double mean_velocity_rad_s = 0.0;
  std::optional<ObserverSummary> observer;  ///< when [observer] is enabled
};

/// A run's account: the board's own, as it sent it (cause, how the output
/// was left, both loops' health, the real-time notes, a move's or a
/// calibration's result), and what only the host knows.
struct RunSummary : AxisMeasured {  ///< its own fields: the run's first axis's
  protocol::RunSummary board;
  /// Every axis of the run in the log's order (the first is the summary's own).
  std::vector<AxisMeasured> axes;
  std::string host_error;   ///< why the host side failed (the log), if it did
  bool board_gone = false;  ///< the board fell silent for good; its end is unknown

  /// "completed", "interrupted" or "failed" (a host failure fails the run).
  [[nodiscard]] std::string status() const;
  /// The firmware's stop cause, or "log_failed" when the host failed.
  [[nodiscard]] std::string stop_cause() const;
  /// A move's run (of one axis or several): each axis has its move's account.
  [[nodiscard]] bool is_move() const;
  /// The board's output state ("confirmed", "output_unconfirmed",
  /// "enable_unconfirmed"), or "unknown" when it fell silent.
  [[nodiscard]] std::string output_state() const;
};

/// What the live status line shows, refreshed a few times a second.
struct LiveStatus {
  double t_s, duration_s, V, theta_rad, residual_rad;
  std::uint64_t sensor_samples, sensor_errors, overruns;
  nlohmann::json board;  ///< the board's last health message (loops, state, a move)
  nlohmann::json
      errors_by_class;    ///< {"drive": {...}, "sensor": {...}}: failed samples by HAL status
  double lease_s = 0.0;   ///< the run's lease on the board
  std::string log_error;  ///< why the log failed (the run then stops), empty while it is well
};

/// How one axis's part of a run ended: a move's end (on_target, timeout,
/// ...) when it ended by itself, else the board's cause.
[[nodiscard]] std::string axis_end(const protocol::RunSummary::Axis& a);

/// The one-machine default: serves `rig` by an in-process piezod and runs
/// what was `asked` through the protocol as a remote run does (run_on_board), until
/// the duration elapses, `stop` is set, the supervisor trips or the log
/// fails (then host_error says why; the drive stops as on `stop`).
/// `on_rows` sees the rows as run_on_board gives them.
[[nodiscard]] RunSummary execute_run(
    const config::ConfigFile& config, const RunAsked& asked, config::Rig rig, RunLog& log,
    const std::atomic<bool>& stop, const std::function<void(const LiveStatus&)>& on_status,
    const std::atomic<bool>* estop = nullptr,
    const std::function<void(const log_schema::AxesRows&)>& on_rows = {});

}  // namespace piezo::host
