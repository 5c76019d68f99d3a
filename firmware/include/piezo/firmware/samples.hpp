#pragma once
/// @file
/// What the real-time loops hand to the host, one record per cycle.

#include <cstdint>

#include "piezo/hal/clock.hpp"
#include "piezo/hal/status.hpp"

namespace piezo::firmware {

/// The drive's phase of a run, logged with every drive sample.
enum class DrivePhase : std::uint8_t {
  driving = 0,         ///< following the waveform
  ramping_down,        ///< stop requested or fault: slewing to 0 V
  stopped,             ///< amplifier disabled, 0 V acknowledged by the drive
  output_unconfirmed,  ///< stopped, but the drive never acknowledged 0 V:
                       ///< V is the last value it did acknowledge
};

struct DriveSample {
  hal::TimeNs t;  ///< when the voltage was written
  double V;       ///< commanded amplifier output [V] (see output_unconfirmed)
  DrivePhase phase;
  hal::Status status;           ///< of the write
  std::uint8_t move_state = 0;  ///< a closed-loop move's MoveState (0: none)
  std::uint8_t axis = 0;        ///< the board's axis (its index in hello.axes)
};

struct SensorSample {
  hal::TimeNs t_request;
  hal::TimeNs t_response;
  double displacement_m;
  hal::Status status;
  std::uint8_t axis = 0;  ///< the board's axis (its index in hello.axes)
};

}  // namespace piezo::firmware
