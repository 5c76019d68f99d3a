#include "board_request.hpp"

#include <fmt/format.h>

#include "piezo/config/config_error.hpp"
#include "piezo/firmware/wire_keys.hpp"
#include "piezo/overload.hpp"
#include "piezo/protocol/dictionary.hpp"

namespace piezo::host {
namespace {

using nlohmann::json;

/// Each command a request sends, with its arguments.
std::vector<std::pair<std::string, json>> wire_requests(const BoardRequest& request) {
  auto sent = std::visit(
      Overload{
          [](const TimedRun& r) -> std::vector<std::pair<std::string, json>> {
            return {{"configure", r.configure}, {"start", r.start}};
          },
          [](const protocol::StepRequest& r) -> std::vector<std::pair<std::string, json>> {
            return {{"step", r}};
          },
          [](const protocol::MoveToRequest& r) -> std::vector<std::pair<std::string, json>> {
            return {{"move_to", r}};
          },
          [](const protocol::CalibrateRequest& r) -> std::vector<std::pair<std::string, json>> {
            return {{"calibrate", r}};
          },
          [&](const protocol::ScanRequest& r) -> std::vector<std::pair<std::string, json>> {
            const std::string cmd(protocol::ScanRequest::kCommand);
            if (request.scans.empty()) return {{cmd, json(r)}};
            // A group: each axis's own arguments under `scans`, the lease beside.
            json group{{wire_key::scans, json::object()}};
            for (const auto& [axis, one] : request.scans) group[wire_key::scans][axis] = one;
            if (r.lease_s) group[wire_key::lease_s] = *r.lease_s;
            return {{cmd, group}};
          },
      },
      request.command);
  if (!request.scans.empty()) return sent;
  if (!request.targets.empty()) {
    // A group move: its targets name the axes.
    for (auto& [cmd, args] : sent) {
      if (cmd != "move_to") continue;
      args.erase(std::string(wire_key::target_rad));
      args[wire_key::targets] = request.targets;
    }
    return sent;
  }
  // The axis goes with each command but `start`, which runs what `configure` set.
  if (request.axis) {
    for (auto& [cmd, args] : sent)
      if (cmd != "start") args[wire_key::axis] = *request.axis;
  }
  return sent;
}

/// The config key a timed run's `configure` argument comes from.
std::string configure_key(const std::string& argument) {
  return argument == wire_key::duration_s ? "run.duration_s" : "drive." + argument;
}

}  // namespace

BoardRequest board_request(const config::HostConfig& host, const RunAsked& asked) {
  const std::optional<double> lease_s =
      host.board.lease_s > 0.0 ? std::optional(host.board.lease_s) : std::nullopt;
  const auto& drive = host.model.drive;
  const std::optional<std::string> axis =
      host.board.axis.empty() ? std::nullopt : std::optional(host.board.axis);
  BoardCommand command = std::visit(
      Overload{
          [&](const asked::Timed&) -> BoardCommand {
            return TimedRun{{drive, host.run.duration_s}, {lease_s}};
          },
          [&](const asked::Periods& p) -> BoardCommand {
            return protocol::StepRequest{p.count, drive, lease_s};
          },
          [&](const asked::Move& m) -> BoardCommand {
            return protocol::MoveToRequest{m, m.V0, m.f, drive.C_dr, drive.e_dr, lease_s};
          },
          [&](const asked::Calibration& c) -> BoardCommand {
            return protocol::CalibrateRequest{c.V0, lease_s};
          },
          [&](const asked::Scan& s) -> BoardCommand {
            // The config's axis's (no name),
            // else each named axis's in `scans`.
            const auto own = s.scans.find("");
            protocol::ScanRequest one =
                own != s.scans.end() ? own->second : protocol::ScanRequest{};
            one.lease_s = lease_s;
            return one;
          },
      },
      asked);
  if (const auto* scan = std::get_if<asked::Scan>(&asked)) {
    // The config's [rig] axis (no name given), or the axes named, by name.
    if (scan->scans.contains("")) return {std::move(command), axis, {}, {}};
    return {std::move(command), {}, {}, scan->scans};
  }
  const auto* move = std::get_if<asked::Move>(&asked);
  if (move != nullptr && !move->targets.empty()) return {std::move(command), {}, move->targets, {}};
  return {std::move(command), axis, {}, {}};
}

void check_request(const BoardRequest& request, const json& dictionary,
                   const std::string& board_address) {
  for (const auto& [cmd, args] : wire_requests(request)) {
    if (const auto breach = protocol::check_arguments(dictionary, cmd, args)) {
      throw config::ConfigError(
          "piezod at " + board_address,
          cmd == "configure" ? configure_key(breach->key) : breach->key,
          fmt::format("{} (the board's dictionary; nothing was sent)", breach->message));
    }
  }
}

void prepare_request(const BoardRequest& request, BoardClient& client) {
  if (!std::holds_alternative<TimedRun>(request.command)) return;
  try {
    (void)client.call("configure", wire_requests(request).front().second);
  } catch (const RemoteError& e) {
    throw config::ConfigError("piezod at " + client.address(), configure_key(e.key()),
                              fmt::format("refused by the board ({}): {}", e.code(), e.what()));
  }
}

json start_request(const BoardRequest& request, BoardClient& client) {
  const auto sent = wire_requests(request);
  const auto& [cmd, args] = sent.back();  // a timed run's configure went before
  return client.call(cmd, args);
}

}  // namespace piezo::host
