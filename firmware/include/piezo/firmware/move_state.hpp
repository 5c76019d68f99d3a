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

/// How a move ended (its account's `stop_cause`): on target, out of time
/// (its run ran the whole timeout), or stopped for its run's cause, one end
/// per cause after `completed`, in the causes' order and under their names.
enum class MoveEnd : std::uint8_t {
  on_target,
  timeout,
  interrupted,
  estop,
  sensor_fault,
  drive_fault,
  link_lost,
  stalled,
  sensor_implausible,
  travel_limit,
  other_axis_fault,
};

/// The ends a stopped run gives: those after `completed`.
inline constexpr std::size_t kMoveEnds =
    2 + static_cast<std::size_t>(kLastStopCause) - static_cast<std::size_t>(StopCause::completed);
static_assert(static_cast<std::size_t>(MoveEnd::other_axis_fault) + 1 == kMoveEnds,
              "a move end for each stop cause after completed");

[[nodiscard]] constexpr MoveEnd move_end(bool on_target, StopCause cause) {
  if (on_target) return MoveEnd::on_target;
  if (cause == StopCause::completed || cause == StopCause::none) return MoveEnd::timeout;
  return static_cast<MoveEnd>(static_cast<std::uint8_t>(cause) -
                              static_cast<std::uint8_t>(StopCause::completed) +
                              static_cast<std::uint8_t>(MoveEnd::timeout));
}

/// Its names: its own two, then the causes' own (kStopCauseNames).
inline constexpr auto kMoveEndNames = [] {
  std::array<std::pair<MoveEnd, std::string_view>, kMoveEnds> entries{};
  entries[0] = {MoveEnd::on_target, "on_target"};
  entries[1] = {MoveEnd::timeout, "timeout"};
  for (std::size_t i = 2; i < kMoveEnds; ++i) {
    const auto cause =
        static_cast<StopCause>(static_cast<std::size_t>(StopCause::completed) + i - 1);
    entries[i] = {move_end(false, cause), to_string(cause)};
  }
  return NameTable<MoveEnd, kMoveEnds>(entries);
}();

static_assert(kMoveEndNames.name(MoveEnd::stalled) == "stalled");

}  // namespace piezo::firmware
