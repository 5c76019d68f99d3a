#pragma once
/// @file
/// Why a run's drive stopped, and the names the wire, the logs and the
/// reports give each cause. Apart from the supervisor that decides it, so
/// that the protocol's codecs need no real-time header.

#include <cstddef>
#include <cstdint>
#include <iterator>
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

/// Whose a stop cause is: the one declaration the drive loop (which causes
/// `fault_stops_all` spreads), the daemon (where a fault latches) and the
/// state machine (whether it latches) read, whatever the count of axes.
enum class CauseScope : std::uint8_t {
  end,    ///< not a fault: the run's own end, or an operator's stop; nothing latches
  axis,   ///< an axis's own fault: that axis stops (every axis with fault_stops_all)
  board,  ///< the board's: it reaches every axis, and latches on the board
};

/// Each cause's scope, by its value (none first).
inline constexpr CauseScope kCauseScopes[] = {
    CauseScope::end,    // none
    CauseScope::end,    // completed
    CauseScope::end,    // interrupted
    CauseScope::board,  // estop
    CauseScope::axis,   // sensor_fault
    CauseScope::axis,   // drive_fault
    CauseScope::board,  // link_lost
    CauseScope::axis,   // stalled
    CauseScope::axis,   // sensor_implausible
    CauseScope::axis,   // travel_limit
    CauseScope::board,  // other_axis_fault
};
static_assert(std::size(kCauseScopes) == static_cast<std::size_t>(kLastStopCause) + 1,
              "every stop cause declares its scope");

[[nodiscard]] constexpr CauseScope scope_of(StopCause c) {
  return kCauseScopes[static_cast<std::size_t>(c)];
}
/// Whether a run (or an axis of it) that ended with `c` latches a fault.
[[nodiscard]] constexpr bool latches(StopCause c) { return scope_of(c) != CauseScope::end; }

}  // namespace piezo::firmware
