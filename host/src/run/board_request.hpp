#pragma once
// What `piezo` asks a board to run, as one typed request decided in one
// place from the command's settings: a timed run (its waveform, then the
// start), whole periods (`step`), a closed-loop move (`move_to`) or the
// calibration experiment (`calibrate`). Checked against the board's own
// dictionary before anything is sent, and sent once.

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <variant>

#include "board_client.hpp"
#include "piezo/protocol/messages.hpp"
#include "config/config_file.hpp"

namespace piezo::host {

/// A timed run: `configure` then `start` (the protocol's only two-request run).
struct TimedRun {
  protocol::ConfigureRequest configure;
  protocol::StartRequest start;
};

using BoardRequest = std::variant<TimedRun, protocol::StepRequest, protocol::MoveToRequest,
                                  protocol::CalibrateRequest>;

/// The request the config's [run] asks for, under the config's `rig.lease_s`
/// (none: the board's default lease).
[[nodiscard]] BoardRequest board_request(const config::ConfigFile& c);

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
