// The host's sections: [run], [move], [observer] and [rig] (sections.hpp).

#include <cstdint>
#include <string>
#include <variant>

#include "piezo/firmware/move_request.hpp"
#include "piezo/model/analysis_limits.hpp"
#include "piezo/overload.hpp"
#include "sections.hpp"

namespace piezo::config::sections {

void read_run(SectionReader r, RunSettings& run, BoardRunSettings& board) {
  r.number("duration_s", run.duration_s, {0.0, 1e6, true}, "s");
  r.choice("clock", board.clock, kRunClockNames);
  r.integer("priority", board.priority, 0, 99);
  r.flag("lock_memory", board.lock_memory);
  r.number("flush_interval_s", run.flush_interval_s, {0.01, 1.0}, "s");
  r.finish();
}

// One key per declared field of a move's request (all but the target).
void read_move(SectionReader r, firmware::MoveRequest& m) {
  for (const firmware::MoveField& field : firmware::kMoveFields) {
    if (field.required) continue;
    const std::string key(field.name);
    std::visit(Overload{
                   [&](double firmware::MoveRequest::*p) {
                     r.number(key, m.*p, field.allowed, std::string(field.unit));
                   },
                   [&](std::uint64_t firmware::MoveRequest::*p) {
                     int v = static_cast<int>(m.*p);
                     r.integer(key, v, static_cast<int>(field.allowed.min),
                               static_cast<int>(field.allowed.max));
                     m.*p = static_cast<std::uint64_t>(v);
                   },
                   [&](bool firmware::MoveRequest::*p) { r.flag(key, m.*p); },
                   [&](firmware::Approach firmware::MoveRequest::*p) {
                     r.choice(key, m.*p, firmware::kApproachNames);
                   },
               },
               field.member);
  }
  r.finish();
}

void read_observer(SectionReader r, ObserverSettings& o) {
  r.flag("enabled", o.enabled);
  r.number("alpha", o.gains.alpha, model::limits::kObserverAlpha);
  r.number("beta", o.gains.beta, model::limits::kObserverBeta);
  r.number("gate_rad", o.gains.gate_rad, model::limits::kObserverGate_rad, "rad");
  r.finish();
}

void read_board_address(SectionReader r, BoardAddress& a) {
  r.text("address", a.address);
  r.number("lease_s", a.lease_s, {0.0, 600.0}, "s");
  r.text("server_public_key_file", a.server_public_key_file);
  r.text("client_secret_key_file", a.client_secret_key_file);
  r.text("axis", a.axis);
  r.finish();
}

}  // namespace piezo::config::sections
