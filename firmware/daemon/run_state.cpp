#include "run_state.hpp"

#include <fmt/format.h>

#include "piezo/protocol/error.hpp"

namespace piezo::daemon {

using protocol::ProtocolError;
namespace code = protocol::code;

void RunState::require_controller(const std::string& client, const char* cmd) const {
  if (controlled() && controller_ != client) {
    throw ProtocolError(code::not_controller, "",
                        fmt::format("{}: another client controls the rig; watch the stream or "
                                    "ask status, or estop",
                                    cmd));
  }
}

void RunState::require_can_start(const std::string& client, const char* cmd) const {
  if (state_ == State::fault) {
    throw ProtocolError(code::fault_latched, "",
                        fmt::format("{}: the fault {} is latched; send reset_fault first", cmd,
                                    firmware::to_string(fault_)));
  }
  if (under_way()) {
    require_controller(client, cmd);
    throw ProtocolError(code::bad_state, "", fmt::format("{}: a run is under way", cmd));
  }
}

void RunState::started(const std::string& client) {
  state_ = State::running;
  controller_ = client;
}

bool RunState::ramping() {
  if (state_ != State::running) return false;
  state_ = State::ramping_down;
  return true;
}

void RunState::ended(firmware::StopCause cause, bool output_confirmed) {
  if (firmware::latches(cause) || !output_confirmed) {
    state_ = State::fault;
    fault_ = firmware::latches(cause) ? cause : firmware::StopCause::drive_fault;
  } else {
    state_ = State::idle;
  }
  controller_.clear();
}

void RunState::estop_at_rest() {
  state_ = State::fault;
  fault_ = firmware::StopCause::estop;
}

firmware::StopCause RunState::reset() {
  if (under_way()) throw ProtocolError(code::bad_state, "", "reset_fault: a run is under way");
  const firmware::StopCause cleared = state_ == State::fault ? fault_ : firmware::StopCause::none;
  state_ = State::idle;
  fault_ = firmware::StopCause::none;
  return cleared;
}

RunState::Latch RunState::latch_of(firmware::StopCause c) {
  switch (firmware::scope_of(c)) {
    case firmware::CauseScope::end:
      return Latch::nowhere;
    case firmware::CauseScope::axis:
      return Latch::on_axis;
    case firmware::CauseScope::board:
      break;
  }
  return Latch::on_board;
}

}  // namespace piezo::daemon
