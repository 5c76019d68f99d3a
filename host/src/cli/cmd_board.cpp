// `piezo status | zero | stop | estop | reset-fault --rig ADDRESS`: talk to a
// running piezod from any terminal (docs/protocol.md).

#include <fmt/format.h>

#include <algorithm>
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "piezo/firmware/wire_keys.hpp"
#include "piezo/protocol/messages.hpp"
#include "run/board_client.hpp"

namespace piezo::host {
namespace {

struct BoardOptions {
  config::BoardAddress rig;
  std::string axis;  ///< `zero`'s axis on a board of several
  bool json = false;
};

/// A calibration as a person reads it.
/// What the axis's readings at rest add: their noise and age, a move at rest.
std::string rest_text(const protocol::RestReport& r) {
  std::string out;
  if (r.noise_rad) out += fmt::format(", noise {:.4f} mrad", 1e3 * *r.noise_rad);
  if (r.age_s) out += fmt::format(", read {:.2f} s ago", *r.age_s);
  if (r.moved) out += fmt::format(", MOVED AT REST by {:.4f} mrad", 1e3 * r.moved_rad);
  if (r.errors > 0) out += fmt::format(", {} failed readings at rest", r.errors);
  return out;
}

std::string calibration_text(const protocol::AxisInfo& axis) {
  const std::optional<protocol::CalibrationRecord>& cal = axis.calibration;
  if (!cal) return "not calibrated (piezo calibrate --rig ADDRESS)";
  std::string scans;
  if (axis.base_rate_rad_per_s && axis.velocity_max_rad_per_s) {
    scans = fmt::format(", scans at {:.4g} to {:.4g} rad/s", *axis.base_rate_rad_per_s,
                        *axis.velocity_max_rad_per_s);
  }
  return fmt::format(
      "calibrated {}: steps fastest at {}, noise {:.3g} m, smallest tolerance {:.3g} rad{}{}",
      cal->created,
      cal->fastest_f_hz ? fmt::format("{:g} Hz", *cal->fastest_f_hz)
                        : std::string("(none reliable)"),
      cal->noise_m, cal->smallest_tolerance_rad.value_or(0.0), scans,
      cal->model.is_object() ? ", model fitted" : "");
}

/// `status`'s reply as a person reads it, from the protocol's own types
/// (what the board sends is decoded once, by the codec that piezod's
/// replies are tested against): the board, the last run with how each of
/// its axes ended, then every axis (its position, fault and calibration,
/// from `hello`), a board of one as a board of several.
std::string status_text(const protocol::Status& s, const protocol::Hello& hello) {
  std::string out = fmt::format("state      {}", protocol::to_string(s.state));
  if (s.fault) out += fmt::format(" (fault: {})", firmware::to_string(*s.fault));
  out += fmt::format("\ncontrolled {}\n", s.controlled ? "yes" : "no");
  if (s.run) {
    const protocol::RunStatus& r = *s.run;
    out += fmt::format("run        {} ({:g} s, lease {:g} s){}\n", r.id, r.duration_s, r.lease_s,
                       r.finished ? ", finished" : "");
    if (r.summary) {
      out += fmt::format("stop cause {}\noutput     {}\n", firmware::to_string(r.summary->cause),
                         firmware::to_string(r.summary->output.state));
      for (const auto& a : r.summary->axes) {
        out += fmt::format(
            "  axis {:<6} {}{}\n", a.name, firmware::to_string(a.cause),
            a.move && a.move->stop_cause
                ? fmt::format(", move {}", firmware::kMoveEndNames.name(*a.move->stop_cause))
            : a.scan && a.scan->stop_cause
                ? fmt::format(", scan {}", firmware::kMoveEndNames.name(*a.scan->stop_cause))
                : std::string());
      }
    }
    out += fmt::format("cycles     drive {}, sensor {} (every sensor line's)\n", r.drive.cycles,
                       r.sensor.cycles);
  }
  for (const protocol::Status::Axis& a : s.axes) {
    const auto info = std::find_if(hello.axes.begin(), hello.axes.end(),
                                   [&](const protocol::AxisInfo& i) { return i.name == a.name; });
    out += fmt::format(
        "axis {:<6} {}{}{}; {}\n", a.name,
        a.position.position_rad
            ? fmt::format("{:.4f} mrad from its zero", 1e3 * *a.position.position_rad)
            : std::string("no reading yet"),
        rest_text(a.rest),
        a.fault ? fmt::format(" (fault: {})", firmware::to_string(*a.fault)) : std::string(),
        info != hello.axes.end() ? calibration_text(*info)
                                 : std::string(a.calibrated ? "calibrated" : "not calibrated"));
  }
  return out;
}

int call(const BoardOptions& o, const std::string& cmd) {
  BoardClient client(o.rig);
  nlohmann::json args = nlohmann::json::object();
  if (cmd == "zero" && !o.axis.empty()) args[wire_key::axis] = o.axis;
  const nlohmann::json result = client.call(cmd == "reset-fault" ? "reset_fault" : cmd, args);
  if (o.json) {
    std::cout << result.dump() << "\n";
  } else if (cmd == "hello") {
    std::cout << result.dump(2) << "\n";
  } else if (cmd == "status") {
    std::cout << status_text(result.get<protocol::Status>(), client.hello());
  } else if (cmd == "zero") {
    std::cout << "zero: set at the last reading; position 0 rad\n";
  } else {
    std::cout << fmt::format("{}: sent; state {}\n", cmd,
                             protocol::to_string(result.get<protocol::StateReply>().state));
  }
  return 0;
}

}  // namespace

void add_board_commands(CLI::App& app, Commands& commands) {
  for (const auto& [name, help] : std::vector<std::pair<std::string, std::string>>{
           {"hello",
            "Print the board's hello: its rates, limits and each axis (radius, "
            "limits, travel window, zero, calibration)"},
           {"status", "Print piezod's state, fault, run and each axis's position"},
           {"zero", "Set the position's zero at the last sensor reading (moves are absolute)"},
           {"stop", "Stop the run (ramp to 0 V); the controlling client only"},
           {"estop", "Emergency stop: disable the amplifier at once, latch the fault"},
           {"reset-fault", "Clear a latched fault (link_lost, estop, ...)"}}) {
    auto o = std::make_shared<BoardOptions>();
    CLI::App* cmd = app.add_subcommand(name, help);
    cmd->add_option("--rig", o->rig.address, "piezod's address, e.g. tcp://127.0.0.1:5555")
        ->required();
    cmd->add_option("--server-key", o->rig.server_public_key_file, "CURVE: the board's .pub file");
    cmd->add_option("--client-key", o->rig.client_secret_key_file, "CURVE: this host's .key file");
    if (name == "zero") {
      cmd->add_option("--axis", o->axis, "The axis to zero (required on a board of several)");
    }
    add_json_flag(*cmd, o->json, "Print the reply as JSON");
    commands.add(cmd, [o, name = name] { return call(*o, name); });
  }
}

}  // namespace piezo::host
