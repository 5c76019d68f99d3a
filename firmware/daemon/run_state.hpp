#pragma once
// The daemon's run state machine and its latching rules, apart from the
// sockets that feed it (docs/protocol.md, "States"): who controls the rig,
// whether a run is under way, and what a run's end leaves behind. Refusals
// are ProtocolErrors, so the daemon answers them as they come.

#include <cstddef>
#include <string>

#include "piezo/firmware/safety_supervisor.hpp"
#include "piezo/protocol/board_state.hpp"

namespace piezo::daemon {

/// The states are the protocol's: the wire names them as RunState keeps them.
using State = protocol::BoardState;

class RunState {
 public:
  [[nodiscard]] State state() const { return state_; }
  /// The latched fault's cause; StopCause::none unless the state is fault.
  [[nodiscard]] firmware::StopCause fault() const { return fault_; }
  /// A run is under way (running or ramping down) from its start until its end is taken.
  [[nodiscard]] bool under_way() const {
    return state_ == State::running || state_ == State::ramping_down;
  }
  /// Some client controls the rig: the one that started the run under way.
  [[nodiscard]] bool controlled() const { return !controller_.empty(); }
  [[nodiscard]] bool is_controller(const std::string& client) const {
    return controlled() && controller_ == client;
  }

  /// Refuses `cmd` (not_controller) from any client but the controller
  /// while one holds the rig.
  void require_controller(const std::string& client, const char* cmd) const;
  /// Refuses a start (`cmd`: start, step, move_to, calibrate) under a
  /// latched fault (fault_latched) or during a run (not_controller from
  /// others, else bad_state).
  void require_can_start(const std::string& client, const char* cmd) const;

  /// A run started by `client`, which controls the rig until it ends.
  void started(const std::string& client);
  /// The drive began its ramp to 0 V; true when that changed the state.
  bool ramping();
  /// The run ended with `cause`: a cause other than completed or
  /// interrupted, or an output not confirmed at 0 V, latches a fault (an
  /// unconfirmed output as drive_fault); nobody controls the rig after.
  void ended(firmware::StopCause cause, bool output_confirmed);
  /// An e-stop with no run under way latches estop.
  void estop_at_rest();
  /// Clears a latched fault (bad_state during a run); returns the cause it
  /// cleared, StopCause::none when there was none.
  firmware::StopCause reset();

  /// Where an axis's end with `cause` latches, whatever the board's count of
  /// axes (its scope, stop_cause.hpp): nowhere (an end), on the axis (its
  /// own fault: the other axes run on), or on the board (the board's causes).
  enum class Latch { nowhere, on_axis, on_board };
  [[nodiscard]] static Latch latch_of(firmware::StopCause cause);

 private:
  State state_ = State::idle;
  firmware::StopCause fault_ = firmware::StopCause::none;
  std::string controller_;  ///< routing id of the controlling client, while a run is on
};

}  // namespace piezo::daemon
