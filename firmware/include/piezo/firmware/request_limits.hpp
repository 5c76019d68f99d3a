#pragma once
/// @file
/// What a drive or a move may ask for, one rule each: a rig config's
/// [drive] and the board's configure/step/move_to/calibrate are checked by
/// the same function, and each caller wraps the answer in its own error
/// (ConfigError naming the file, ProtocolError out_of_limits on the wire).

#include <cstdint>
#include <limits>
#include <optional>
#include <string>

#include "piezo/firmware/voltage_limiter.hpp"
#include "piezo/model/parameters.hpp"

namespace piezo::firmware {

/// A requested value beyond what is allowed: the key as a request names it
/// (V0, f, ...) and a message giving the value and the allowed range
/// (without the key: each caller puts its own name in front).
struct LimitBreach {
  std::string key;
  std::string message;
};

/// What the drive can do.
struct DriveBounds {
  VoltageLimits limits;
  double rate_hz = 0.0;  ///< the drive loop's rate: at least 20 updates a period
  double duration_max_s = std::numeric_limits<double>::infinity();
};

/// The sawtooth's peak, frequency and rise fraction against the limits,
/// and the run's length: V0 in (0, V_max] with V_min <= 0, f in
/// (0, rate/20], C_dr in (0, 1], e_dr in [0, 1), D in (0, 1), the fastest
/// edge V0·f/min(D, 1−D) within the slew limit, duration in (0, max].
[[nodiscard]] std::optional<LimitBreach> check_drive(const model::DriveParameters& drive,
                                                     double duration_s, const DriveBounds& bounds);

/// What a move asks for besides its waveform.
struct MoveRequest {
  double target_rad = 0.0;
  double tolerance_rad = 25e-6;
  double settle_s = 0.1;
  double timeout_s = 30.0;
  double hold_s = 0.0;
  std::uint64_t stall_steps = 2;  ///< as the wire carries it: unsigned, unbounded
};

/// target within ±10 rad, tolerance in (0, 0.1] rad, settle in [0, 10] s,
/// timeout in (0, max], hold in [0, timeout), stall steps in 1..16.
[[nodiscard]] std::optional<LimitBreach> check_move(
    const MoveRequest& move, double timeout_max_s = std::numeric_limits<double>::infinity());

}  // namespace piezo::firmware
