#pragma once
/// @file
/// Why a run's drive stopped, and the names the wire, the logs and the
/// reports give each cause. Apart from the supervisor that decides it, so
/// that the protocol's codecs need no real-time header.

#include <cstdint>
#include <string_view>

#include "piezo/name_table.hpp"

namespace piezo::firmware {

/// Why the drive stopped; `none` while it runs.
enum class StopCause : std::uint8_t {
  none = 0,
  completed,    ///< the configured duration elapsed
  interrupted,  ///< SIGINT/SIGTERM or an operator stop
  estop,
  sensor_fault,
  drive_fault,
  link_lost,           ///< the controlling client's lease expired (host gone, network down)
  stalled,             ///< a move made no progress over its stall steps
  sensor_implausible,  ///< a move's readings are no driven rotor's (frozen, against the drive)
  travel_limit,        ///< the measured angle left safety.travel_min_rad..travel_max_rad
  other_axis_fault,    ///< another axis's fault stopped the board (safety.fault_stops_all,
                       ///< or its drive could not confirm 0 V)
};
/// The last StopCause, for code that goes through them all.
inline constexpr StopCause kLastStopCause = StopCause::other_axis_fault;

inline constexpr auto kStopCauseNames =
    names<StopCause>({{StopCause::none, "none"},
                      {StopCause::completed, "completed"},
                      {StopCause::interrupted, "interrupted"},
                      {StopCause::estop, "estop"},
                      {StopCause::sensor_fault, "sensor_fault"},
                      {StopCause::drive_fault, "drive_fault"},
                      {StopCause::link_lost, "link_lost"},
                      {StopCause::stalled, "stalled"},
                      {StopCause::sensor_implausible, "sensor_implausible"},
                      {StopCause::travel_limit, "travel_limit"},
                      {StopCause::other_axis_fault, "other_axis_fault"}});

[[nodiscard]] constexpr std::string_view to_string(StopCause c) {
  return kStopCauseNames.name(c);
}

}  // namespace piezo::firmware
