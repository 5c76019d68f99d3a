#pragma once
// The rig a run talks to, built from the config's backend choices: the one
// place where backends are named. Everything is built and checked before
// the run directory is created or the amplifier enabled.

#include <functional>
#include <memory>
#include <vector>

#include "piezo/hal/clock.hpp"
#include "piezo/hal/digital_lines.hpp"
#include "piezo/hal/displacement_sensor.hpp"
#include "piezo/hal/drive.hpp"
#include "run_config.hpp"

namespace piezo::config {

struct Rig {
  std::unique_ptr<hal::Clock> clock;
  hal::TimeNs t0 = 0;  ///< the run's time origin, fixed by start_at() once set-up is done
  /// What the devices below are built on (the simulated plant, GPIO line
  /// groups); declared first so that it outlives them.
  std::vector<std::shared_ptr<void>> parts;
  std::unique_ptr<hal::Drive> drive;
  std::unique_ptr<hal::DisplacementSensor> sensor;
  std::unique_ptr<hal::DigitalLines> lines;
  /// Told the time origin before the run starts (the simulated devices).
  std::vector<std::function<void(hal::TimeNs)>> on_start;

  /// Fixes the run's time origin: called after every slow set-up step, so
  /// that the first deadline is not already late.
  void start_at(hal::TimeNs time_origin) {
    t0 = time_origin;
    for (const auto& tell : on_start) tell(t0);
  }
};

/// Builds the clock and the backends; throws ConfigError when the drive
/// hardware cannot honour the configured limits, std::runtime_error when a
/// device cannot be reached.
[[nodiscard]] Rig build_rig(const RunConfig& config);

/// Just the sensor, on the real clock: for `piezo sensor read`.
struct SensorRig {
  std::unique_ptr<hal::Clock> clock;
  std::vector<std::shared_ptr<void>> parts;
  std::unique_ptr<hal::DisplacementSensor> sensor;
};
[[nodiscard]] SensorRig build_sensor(const RunConfig& config);

}  // namespace piezo::config

// The host reads rig configs through the same names.
namespace piezo::host {
using namespace piezo::config;  // NOLINT(google-build-using-namespace)
}  // namespace piezo::host
