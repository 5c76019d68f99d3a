#pragma once
// One axis as piezod serves it: its config and devices, and what the board
// keeps for it between runs (its zero, its calibration, its latest readings
// at rest, the model's step tables for it). Internal to the daemon's sources.

#include <cstddef>
#include <deque>
#include <optional>
#include <string>

#include "config/config_file.hpp"
#include "config/rig.hpp"
#include "piezo/firmware/angle_zero.hpp"
#include "piezo/firmware/move_planner.hpp"
#include "piezo/firmware/rest_watch.hpp"
#include "piezo/protocol/messages.hpp"

namespace piezo::daemon {

struct ServedAxis {
  ServedAxis(std::size_t index_, const config::AxisConfig& config_, config::RigAxis& rig_,
             std::string calibration_file_)
      : index(index_),
        config(config_),
        rig(rig_),
        calibration_file(std::move(calibration_file_)),
        planner(config_.model.motor) {}

  static constexpr std::size_t kRecentReadings = 8;  ///< averaged for a position

  std::size_t index;  ///< in the board's order (hello.axes)
  const config::AxisConfig& config;
  config::RigAxis& rig;
  /// Where its calibration is kept across restarts (empty: in memory only).
  std::string calibration_file;
  /// The angle's zero: set by `zero` or a move, else the first good reading
  /// since the daemon started.
  firmware::AngleZero zero;
  /// Its own latched fault on a board of several (none: it may run):
  /// set by a run that ended with this axis's own fault, cleared by reset_fault.
  firmware::StopCause fault = firmware::StopCause::none;
  /// The installed calibration (docs/protocol.md, "Calibration"), if any.
  std::optional<protocol::CalibrationRecord> calibration;
  std::deque<double> recent_readings;  ///< the last good readings of any run
  firmware::MovePlanner planner;       ///< the model's step tables, per waveform
  /// Its readings at rest since its last run ended (or the board started).
  firmware::RestWatch rest;
  std::int64_t last_good_wall_ns = 0;  ///< steady time of its latest good reading (0: none)
  std::uint64_t rest_errors = 0;       ///< idle readings that failed in this rest
  bool last_idle_failed = false;       ///< its latest idle reading failed

  [[nodiscard]] const std::string& name() const { return config.name; }
  void remember_reading(double displacement_m) {
    recent_readings.push_back(displacement_m);
    if (recent_readings.size() > kRecentReadings) recent_readings.pop_front();
  }
  /// The mean of the latest readings (nullopt: none yet).
  [[nodiscard]] std::optional<double> recent_displacement_m() const {
    if (recent_readings.empty()) return std::nullopt;
    double sum = 0.0;
    for (const double d : recent_readings) sum += d;
    return sum / static_cast<double>(recent_readings.size());
  }
};

}  // namespace piezo::daemon
