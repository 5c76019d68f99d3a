#pragma once
// The board's calibration: what `calibrate` measured (the step table by
// direction, amplitude and frequency, the angle per volt in stick, the
// sensor's noise), the figures derived from it (the fastest reliable
// frequency, the resolution and the smallest tolerance a move may ask for),
// and a host's fitted model beside it, as protocol::CalibrationRecord
// (docs/protocol.md, "Calibration"); checked on every way in (a run's result, `set_calibration`,
// the file the board persists it in), and applied to moves.

#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "piezo/firmware/calibration_program.hpp"
#include "piezo/firmware/move_controller.hpp"
#include "piezo/firmware/velocity_branch.hpp"
#include "piezo/protocol/messages.hpp"

namespace piezo::daemon {

/// What a calibration must agree with: the board's limits.
struct CalibrationLimits {
  double V_max = 0.0;
  double f_max_hz = 0.0;
};

/// The calibration a finished experiment gives (created: the board's UTC time).
[[nodiscard]] protocol::CalibrationRecord measured_calibration(
    const firmware::CalibrationPlan& plan, const firmware::CalibrationResult& result);

/// Checks a calibration (a client's, a file's, or one measured) against the
/// ranges its field list declares and the board's limits, and returns it
/// with its derived figures recomputed; throws ProtocolError
/// (bad_argument) naming the key as `calibration.KEY`.
[[nodiscard]] protocol::CalibrationRecord checked_calibration(protocol::CalibrationRecord c,
                                                              const CalibrationLimits& limits);
[[nodiscard]] protocol::CalibrationRecord checked_calibration(const nlohmann::json& given,
                                                              const CalibrationLimits& limits);

/// A reading's noise [m] as an angle's resolution: the settle's best
/// confidence half-width, twice the standard error of its longest mean.
[[nodiscard]] double resolution_rad(double noise_m, double r2_m);
/// The smallest tolerance a move may ask for with this noise [rad].
[[nodiscard]] double smallest_tolerance_rad(double noise_m, double r2_m);

/// Fills a move's step tables, frequency, angle per volt and noise from the
/// calibration. `f` is the frequency the caller asked for (none: the
/// calibration's fastest); false when the calibration has no table for it
/// at the move's V0 (the model's predictions stay).
bool apply_calibration(const protocol::CalibrationRecord& c, std::optional<double> f,
                       firmware::MoveSettings& m);

/// The axis's steady velocity against its drive one way (+1 forward), as
/// the calibration measured it (its reliable frequencies' step tables).
[[nodiscard]] firmware::VelocityBranch velocity_branch(const protocol::CalibrationRecord& c,
                                                       int direction);
/// A scan's velocities that hold both ways [rad/s] (top 0: none).
struct VelocityRange {
  double base_rate = 0.0, top = 0.0;
};
[[nodiscard]] VelocityRange velocity_range(const protocol::CalibrationRecord& c);

/// The calibration kept in `path` (none when the file does not exist);
/// throws std::runtime_error naming the file when it cannot be used.
[[nodiscard]] std::optional<protocol::CalibrationRecord> load_calibration(
    const std::string& path, const CalibrationLimits& limits);
/// Writes it atomically (a new file renamed over the old one, synced).
void save_calibration(const std::string& path, const protocol::CalibrationRecord& c);

}  // namespace piezo::daemon
