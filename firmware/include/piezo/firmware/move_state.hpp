#pragma once
/// @file
/// A closed-loop move's state (the drive records' `move_state`) and how a
/// move ended (its account's `stop_cause`), with the names the wire gives
/// them. Apart from the controller, so that the protocol needs no
/// real-time header.

#include <array>
#include <cstdint>
#include <string_view>

#include "piezo/firmware/stop_cause.hpp"
#include "piezo/name_table.hpp"

namespace piezo::firmware {

enum class MoveState : std::uint8_t {
  none = 0,
  coarse = 1,
  fine = 2,
  release = 3,
  settle = 4,
  on_target = 5,
  stalled = 6,             ///< no progress over stall_steps steps: the run stops
  sensor_implausible = 7,  ///< readings no driven rotor gives: the run stops
  holding = 8,             ///< on target, the fine servo kept on for hold_s
};

inline constexpr auto kMoveStateNames =
    names<MoveState>({{MoveState::none, "none"},
                      {MoveState::coarse, "coarse"},
                      {MoveState::fine, "fine"},
                      {MoveState::release, "release"},
                      {MoveState::settle, "settle"},
                      {MoveState::on_target, "on_target"},
                      {MoveState::stalled, "stalled"},
                      {MoveState::sensor_implausible, "sensor_implausible"},
                      {MoveState::holding, "holding"}});

/// How a move ended: on target, out of time (its run ran the whole
/// timeout), or stopped for its run's cause (stalled, estop, link_lost, ...).
[[nodiscard]] constexpr std::string_view move_end(bool on_target, StopCause cause) {
  if (on_target) return "on_target";
  if (cause == StopCause::completed) return "timeout";
  return to_string(cause);
}

/// Every name `move_end` gives, in order.
[[nodiscard]] constexpr auto move_end_names() {
  std::array<std::string_view, 2 + static_cast<std::size_t>(kLastStopCause) - 1> out{};
  out[0] = move_end(true, StopCause::none);
  out[1] = move_end(false, StopCause::completed);
  std::size_t i = 2;
  for (auto c = static_cast<std::uint8_t>(StopCause::completed) + 1;
       c <= static_cast<std::uint8_t>(kLastStopCause); ++c) {
    out[i++] = to_string(static_cast<StopCause>(c));
  }
  return out;
}

}  // namespace piezo::firmware
