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

#include "piezo/firmware/move_request.hpp"
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

/// The highest sawtooth frequency a drive loop of `rate_hz` updates at
/// least 20 times a period: every request, plan and report asks this.
[[nodiscard]] constexpr double max_drive_frequency(double rate_hz) {
  return rate_hz / 20.0;
}

/// The stator's DC holds (a move's fine servo, a calibration's holds) stay
/// within this fraction of V_max, so the fine stage keeps headroom.
inline constexpr double kHoldFractionOfVmax = 0.8;

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

/// Every field within its declared interval (kMoveFields), the timeout
/// also within the board's longest run, and hold below the timeout.
[[nodiscard]] std::optional<LimitBreach> check_move(
    const MoveRequest& move, double timeout_max_s = std::numeric_limits<double>::infinity());

}  // namespace piezo::firmware
