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

/// The simulated rig: each axis's drive and sensor share its plant, the
/// lines reach every plant, so it is made once from the backends' sections.
std::shared_ptr<hal::sim::SimRig> make_sim_rig(const BoardConfig& c, hal::Clock& clock,
                                               hal::TimeNs t0) {
  std::vector<hal::sim::SimAxisSettings> axes;
  for (std::size_t i = 0; i < c.axes.size(); ++i) {
    const AxisConfig& a = c.axes[i];
    const auto& drive = a.drive.backends.get<hal::sim::SimDriveBackend>();
    const hal::DriveCommon common = c.drive_common(i);
    axes.push_back(
        {a.plant, drive.amplifier(common), drive.dac(common),
         a.sensor.backends.get<hal::sim::SimSensorBackend>().settings(c.sensor_common(i)),
         a.plant_end_stop_rad, a.plant_coupling});
  }
  return std::make_shared<hal::sim::SimRig>(
      axes, c.lines.backends.get<hal::sim::SimLinesBackend>().settings(), clock, t0);
}

std::unique_ptr<hal::DisplacementSensor> held_to_range(const AxisConfig& a,
                                                       hal::DisplacementSensor& sensor) {
  return std::make_unique<hal::RangeCheckedSensor>(sensor, a.sensor.range_min_m,
                                                   a.sensor.range_max_m);
}

}  // namespace

Rig build_rig(const BoardConfig& c) {
  Rig rig;
  rig.clock = make_clock(c.run.clock);
  rig.t0 = rig.clock->now();
  // The config checks that simulated backends come together.
  if (c.axis().drive.backends.chosen().simulated()) rig.sim = make_sim_rig(c, *rig.clock, rig.t0);
  hal::OpenContext context{*rig.clock, rig.sim};
  for (std::size_t i = 0; i < c.axes.size(); ++i) {
    const AxisConfig& a = c.axes[i];
    context.axis = i;
    RigAxis& axis = rig.axes.emplace_back();
    axis.own_drive = a.drive.backends.chosen().open(c.drive_common(i), context);
    axis.own_sensor = a.sensor.backends.chosen().open(c.sensor_common(i), context);
    axis.drive = axis.own_drive.get();
    axis.checked_sensor = held_to_range(a, *axis.own_sensor);
    axis.sensor = axis.checked_sensor.get();
    const hal::DriveLimits hw = axis.drive->limits();
    check_drive_hardware(c, i, hw.V_min, hw.V_max);
  }
  rig.own_lines = c.lines.backends.chosen().open({}, context);
  rig.lines = rig.own_lines.get();
  if (rig.sim && !c.lines.backends.chosen().simulated()) {
    // Simulated amplifiers with the board's real lines (a GPIO chip, a DAQ
    // card, none): no enable line reaches them, so they are always on, as
    // a bench amplifier without an enable input is.
    (void)rig.sim->lines().set_amplifier_enable(true);
  }
  return rig;
}

SensorRig build_sensor(const BoardConfig& c, std::size_t axis) {
  SensorRig s;
  s.clock = std::make_unique<hal::posix::MonotonicClock>();
  const AxisConfig& a = c.axis(axis);
  const auto& backend = a.sensor.backends.chosen();
  hal::OpenContext context{*s.clock, nullptr, axis};
  if (backend.simulated()) context.sim = make_sim_rig(c, *s.clock, s.clock->now());
  s.own_sensor = backend.open(c.sensor_common(axis), context);
  s.checked_sensor = held_to_range(a, *s.own_sensor);
  s.sensor = s.checked_sensor.get();
  return s;
}

}  // namespace piezo::config
