#include "rig.hpp"

#include "piezo/hal/posix/monotonic_clock.hpp"
#include "piezo/hal/range_checked_sensor.hpp"
#include "piezo/hal/sim/sim_backends.hpp"
#include "piezo/hal/sim/virtual_clock.hpp"

namespace piezo::config {
namespace {

std::unique_ptr<hal::Clock> make_clock(RunClock clock) {
  switch (clock) {
    case RunClock::virtual_time:
      return std::make_unique<hal::sim::VirtualClock>();
    case RunClock::realtime:
      return std::make_unique<hal::posix::MonotonicClock>();
  }
  return nullptr;
}

/// The simulated rig: its drive, sensor and lines share one plant, so it is
/// made once from the three backends' sections.
std::shared_ptr<hal::sim::SimRig> make_sim_rig(const BoardConfig& c, hal::Clock& clock,
                                               hal::TimeNs t0) {
  const auto& drive = c.drive.backends.get<hal::sim::SimDriveBackend>();
  const hal::DriveCommon common = c.drive_common();
  const hal::sim::SimAxisSettings axis{
      c.plant, drive.amplifier(common), drive.dac(common),
      c.sensor.backends.get<hal::sim::SimSensorBackend>().settings(c.sensor.common()),
      c.plant_end_stop_rad};
  return std::make_shared<hal::sim::SimRig>(
      std::vector<hal::sim::SimAxisSettings>{axis},
      c.lines.backends.get<hal::sim::SimLinesBackend>().settings(), clock, t0);
}

std::unique_ptr<hal::DisplacementSensor> held_to_range(const BoardConfig& c,
                                                       hal::DisplacementSensor& sensor) {
  return std::make_unique<hal::RangeCheckedSensor>(sensor, c.sensor.range_min_m,
                                                   c.sensor.range_max_m);
}

}  // namespace

Rig build_rig(const BoardConfig& c) {
  Rig rig;
  rig.clock = make_clock(c.run.clock);
  rig.t0 = rig.clock->now();
  // The config checks that simulated backends come together.
  if (c.drive.backends.chosen().simulated()) rig.sim = make_sim_rig(c, *rig.clock, rig.t0);
  hal::OpenContext context{*rig.clock, rig.sim};
  rig.own_drive = c.drive.backends.chosen().open(c.drive_common(), context);
  rig.own_sensor = c.sensor.backends.chosen().open(c.sensor.common(), context);
  rig.own_lines = c.lines.backends.chosen().open({}, context);
  rig.drive = rig.own_drive.get();
  rig.checked_sensor = held_to_range(c, *rig.own_sensor);
  rig.sensor = rig.checked_sensor.get();
  rig.lines = rig.own_lines.get();

  const hal::DriveLimits hw = rig.drive->limits();
  check_drive_hardware(c, hw.V_min, hw.V_max);
  return rig;
}

SensorRig build_sensor(const BoardConfig& c) {
  SensorRig s;
  s.clock = std::make_unique<hal::posix::MonotonicClock>();
  const auto& backend = c.sensor.backends.chosen();
  hal::OpenContext context{*s.clock, nullptr};
  if (backend.simulated()) context.sim = make_sim_rig(c, *s.clock, s.clock->now());
  s.own_sensor = backend.open(c.sensor.common(), context);
  s.checked_sensor = held_to_range(c, *s.own_sensor);
  s.sensor = s.checked_sensor.get();
  return s;
}

}  // namespace piezo::config
