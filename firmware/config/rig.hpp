#pragma once
// The rig a run talks to, built from the config's backend choices: the one
// place where the chosen backends (hal/registry) open their devices. Everything
// is built and checked before the run directory is created or the
// amplifier enabled.

#include <memory>
#include <vector>

#include "config_file.hpp"
#include "piezo/hal/clock.hpp"
#include "piezo/hal/digital_lines.hpp"
#include "piezo/hal/displacement_sensor.hpp"
#include "piezo/hal/drive.hpp"
#include "piezo/hal/sim/sim_rig.hpp"

namespace piezo::config {

/// One axis's devices, as its chosen backends opened them.
struct RigAxis {
  /// The devices the chosen backends opened (a simulated one shares the
  /// rig's ownership).
  std::shared_ptr<hal::Drive> own_drive;
  std::shared_ptr<hal::DisplacementSensor> own_sensor;
  /// The sensor held to sensor.range_min_m/range_max_m.
  std::unique_ptr<hal::DisplacementSensor> checked_sensor;
  /// The run's devices: the ones above.
  hal::Drive* drive = nullptr;
  hal::DisplacementSensor* sensor = nullptr;
};

struct Rig {
  std::unique_ptr<hal::Clock> clock;
  hal::TimeNs t0 = 0;  ///< the run's time origin, fixed by start_at() once set-up is done
  /// The simulated rig when the backends are "sim" (one plant per axis);
  /// shared so that a check can keep reading the device side after the run
  /// has taken the rig.
  std::shared_ptr<hal::sim::SimRig> sim;
  std::vector<RigAxis> axes;  ///< in the config's order
  /// The board's lines: one enable, sync and e-stop for every axis.
  std::shared_ptr<hal::DigitalLines> own_lines;
  hal::DigitalLines* lines = nullptr;

  /// Fixes the run's time origin: called after every slow set-up step, so
  /// that the first deadline is not already late.
  void start_at(hal::TimeNs time_origin) {
    t0 = time_origin;
    if (sim) sim->set_time_origin(t0);
  }
};

/// Builds the clock and the backends; throws ConfigError when the drive
/// hardware cannot honour the configured limits, std::runtime_error when a
/// device cannot be reached.
[[nodiscard]] Rig build_rig(const BoardConfig& config);

/// Just one axis's sensor, on the real clock: for `piezo sensor read`.
struct SensorRig {
  std::unique_ptr<hal::Clock> clock;
  std::shared_ptr<hal::DisplacementSensor> own_sensor;
  std::unique_ptr<hal::DisplacementSensor> checked_sensor;  ///< as in Rig
  hal::DisplacementSensor* sensor = nullptr;
};
[[nodiscard]] SensorRig build_sensor(const BoardConfig& config, std::size_t axis = 0);

}  // namespace piezo::config
