#pragma once
// What `piezo` asks a board to run, as one typed request decided in one
// place from the command's settings: a timed run (its waveform, then the
// start), whole periods (`step`), a closed-loop move (`move_to`), the
// calibration experiment (`calibrate`) or a scan (`scan`). Checked against the board's own
// dictionary before anything is sent, and sent once.

#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <variant>

#include "board_client.hpp"
#include "config/config_file.hpp"
#include "piezo/protocol/messages.hpp"

namespace piezo::host {

/// A timed run: `configure` then `start` (the protocol's only two-request run).
struct TimedRun {
  protocol::ConfigureRequest configure;
  protocol::StartRequest start;
};

using BoardCommand = std::variant<TimedRun, protocol::StepRequest, protocol::MoveToRequest,
                                  protocol::CalibrateRequest, protocol::ScanRequest>;

/// A command and the board's axis it drives.
struct BoardRequest {
  BoardCommand command;
  std::optional<std::string> axis;  ///< [rig] axis; none: the board's one axis
  /// A group move's targets, {axis: target_rad} (its `move_to` names no
  /// `axis` nor `target_rad`); empty: one axis's command.
  std::map<std::string, double> targets;
  /// A group scan's, each axis's own request (its `scan` names `scans` and
  /// no `axis`; the command's ScanRequest gives only its lease); empty: one
  /// axis's command.
  std::map<std::string, protocol::ScanRequest> scans;
};

/// What a run command asks for, beside the host's config (none of it is a
/// config key): the command's own choice, with what the user gave it.
namespace asked {
struct Timed {};  ///< `piezo run`: [drive]'s waveform for [run] duration_s
struct Periods {  ///< `piezo step`: whole drive periods
  std::uint64_t count = 0;
};
struct Move : firmware::MoveRequest {  ///< `piezo move`
  /// The coarse steps' waveform when the user named it; else the board
  /// chooses (its calibration's fastest frequency, or its [drive]).
  std::optional<double> V0 = std::nullopt, f = std::nullopt;
  /// A group move's targets, {axis: target_rad}; empty: target_rad on [rig] axis.
  std::map<std::string, double> targets = {};
};
struct Calibration {  ///< `piezo calibrate`, at V0 when the user named it; else the board's
  std::optional<double> V0 = std::nullopt;
};
struct Scan {  ///< `piezo scan`: each axis's scan, by name ("": the [rig] axis, alone)
  std::map<std::string, protocol::ScanRequest> scans;
};
}  // namespace asked
using RunAsked =
    std::variant<asked::Timed, asked::Periods, asked::Move, asked::Calibration, asked::Scan>;

/// The request for what was asked, with the host config's waveform where
/// it needs one, under its `[rig] lease_s` (none: the board's default
/// lease), on its `[rig] axis`.
[[nodiscard]] BoardRequest board_request(const config::HostConfig& host, const RunAsked& asked);

/// Refuses (ConfigError naming the argument, the board and its limit) what
/// the board's dictionary (`describe`) says it would refuse: nothing is sent.
void check_request(const BoardRequest& request, const nlohmann::json& dictionary,
                   const std::string& board_address);

/// Sends what comes before the run's start (a timed run's `configure`; a
/// refusal becomes a ConfigError naming the config key), before any log exists.
void prepare_request(const BoardRequest& request, BoardClient& client);

/// Starts the run: the one request that does (its reply, as the protocol gives it).
[[nodiscard]] nlohmann::json start_request(const BoardRequest& request, BoardClient& client);

}  // namespace piezo::host
