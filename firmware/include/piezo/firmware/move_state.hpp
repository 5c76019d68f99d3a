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
/// (its run ran the whole timeout), or stopped for its run's cause.
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
};

inline constexpr auto kMoveEndNames =
    names<MoveEnd>({{MoveEnd::on_target, "on_target"},
                    {MoveEnd::timeout, "timeout"},
                    {MoveEnd::interrupted, "interrupted"},
                    {MoveEnd::estop, "estop"},
                    {MoveEnd::sensor_fault, "sensor_fault"},
                    {MoveEnd::drive_fault, "drive_fault"},
                    {MoveEnd::link_lost, "link_lost"},
                    {MoveEnd::stalled, "stalled"},
                    {MoveEnd::sensor_implausible, "sensor_implausible"},
                    {MoveEnd::travel_limit, "travel_limit"}});

/// A run's causes past `completed` are a move's ends past `timeout`, in order.
[[nodiscard]] constexpr MoveEnd move_end(bool on_target, StopCause cause) {
  if (on_target) return MoveEnd::on_target;
  if (cause == StopCause::completed || cause == StopCause::none) return MoveEnd::timeout;
  return static_cast<MoveEnd>(static_cast<std::uint8_t>(cause) -
                              static_cast<std::uint8_t>(StopCause::completed) +
                              static_cast<std::uint8_t>(MoveEnd::timeout));
}

static_assert(kMoveEndNames.name(move_end(false, StopCause::travel_limit)) ==
              to_string(StopCause::travel_limit));
static_assert(kMoveEndNames.name(move_end(false, StopCause::interrupted)) ==
              to_string(StopCause::interrupted));
static_assert(kMoveEndNames.entries().size() == static_cast<std::size_t>(kLastStopCause) -
                                                    static_cast<std::size_t>(StopCause::completed) +
                                                    2);

}  // namespace piezo::firmware
