#include "rig.hpp"

#include "piezo/hal/posix/monotonic_clock.hpp"
#include "piezo/hal/sim/plant.hpp"
#include "piezo/hal/sim/sim_drive.hpp"
#include "piezo/hal/sim/sim_lines.hpp"
#include "piezo/hal/sim/sim_sensor.hpp"
#include "piezo/hal/sim/virtual_clock.hpp"

namespace piezo::host {
namespace {

// Time for the loop threads to start and set themselves up before t0.
constexpr double kStartLead_s = 0.1;

}  // namespace

Rig build_rig(const RunConfig& c) {
  Rig rig;
  if (c.virtual_clock()) {
    rig.clock = std::make_unique<hal::sim::VirtualClock>();
  } else {
    rig.clock = std::make_unique<hal::posix::MonotonicClock>();
  }
  rig.t0 = rig.clock->now() + hal::from_seconds(kStartLead_s);

  // Only the simulated backends exist so far; the config reader admits no others.
  hal::sim::AmplifierSettings amplifier = c.drive.amplifier;
  auto plant = std::make_shared<hal::sim::Plant>(c.plant, amplifier, rig.clock->now());
  rig.drive = std::make_unique<hal::sim::SimDrive>(c.drive.dac, *plant, *rig.clock, rig.t0);
  rig.sensor = std::make_unique<hal::sim::SimSensor>(c.sensor.sim, *plant, *rig.clock, rig.t0);
  rig.lines = std::make_unique<hal::sim::SimLines>(c.lines.sim, *plant, *rig.clock, rig.t0);
  rig.shared_devices = plant;

  const hal::DriveLimits hw = rig.drive->limits();
  check_drive_hardware(c, hw.V_min, hw.V_max);
  return rig;
}

}  // namespace piezo::host
