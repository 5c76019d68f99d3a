#include "rig.hpp"

#include "piezo/hal/gpiod/gpiod_rig.hpp"
#include "piezo/hal/modbus/modbus_analog_output.hpp"
#include "piezo/hal/modbus/modbus_sensor.hpp"
#include "piezo/hal/posix/monotonic_clock.hpp"
#include "piezo/hal/posix/no_lines.hpp"
#include "piezo/hal/range_checked_sensor.hpp"
#include "piezo/hal/sim/virtual_clock.hpp"

namespace piezo::config {
namespace {

constexpr const char* kConsumer = "piezo";

std::unique_ptr<hal::Clock> make_clock(RunClock clock) {
  switch (clock) {
    case RunClock::virtual_time:
      return std::make_unique<hal::sim::VirtualClock>();
    case RunClock::realtime:
      return std::make_unique<hal::posix::MonotonicClock>();
  }
  return nullptr;
}

hal::sim::SimRigSettings sim_rig_settings(const RigConfig& c) {
  return {c.plant, c.drive.amplifier, c.drive.dac, c.sensor.sim, c.lines.sim, c.plant_end_stop_rad};
}

std::unique_ptr<hal::DisplacementSensor> make_modbus_sensor(const RigConfig& c,
                                                            const hal::Clock& clock) {
  return std::make_unique<hal::modbus::ModbusSensor>(c.sensor.link, c.sensor.map, clock);
}

std::unique_ptr<hal::DisplacementSensor> held_to_range(const RigConfig& c,
                                                       hal::DisplacementSensor& sensor) {
  return std::make_unique<hal::RangeCheckedSensor>(sensor, c.sensor.range_min_m,
                                                   c.sensor.range_max_m);
}

}  // namespace

Rig build_rig(const RigConfig& c) {
  Rig rig;
  rig.clock = make_clock(c.run.clock);
  rig.t0 = rig.clock->now();
  // The simulated drive, sensor and lines share one plant (the config
  // checks that "sim" backends come together).
  if (c.drive.backend == DriveBackend::sim) {
    rig.sim = std::make_shared<hal::sim::SimRig>(sim_rig_settings(c), *rig.clock, rig.t0);
  }
  switch (c.drive.backend) {
    case DriveBackend::sim:
      rig.drive = &rig.sim->drive();
      break;
    case DriveBackend::modbus_ao:
      rig.own_drive =
          std::make_unique<hal::modbus::ModbusAnalogOutput>(c.drive.ao_link, c.drive.ao);
      break;
    case DriveBackend::gpiod_dac:
      rig.own_drive = std::make_unique<hal::gpiod::GpiodParallelDac>(c.drive.gpio_dac, kConsumer);
      break;
  }
  switch (c.sensor.backend) {
    case SensorBackend::sim:
      rig.sensor = &rig.sim->sensor();
      break;
    case SensorBackend::modbus_tcp:
    case SensorBackend::modbus_rtu:
      rig.own_sensor = make_modbus_sensor(c, *rig.clock);
      break;
  }
  switch (c.lines.backend) {
    case LinesBackend::sim:
      rig.lines = &rig.sim->lines();
      break;
    case LinesBackend::gpiod:
      rig.own_lines = std::make_unique<hal::gpiod::GpiodRigLines>(c.lines.gpiod, kConsumer);
      break;
    case LinesBackend::none:
      rig.own_lines = std::make_unique<hal::posix::NoLines>();
      break;
  }
  if (rig.own_drive) rig.drive = rig.own_drive.get();
  if (rig.own_sensor) rig.sensor = rig.own_sensor.get();
  rig.checked_sensor = held_to_range(c, *rig.sensor);
  rig.sensor = rig.checked_sensor.get();
  if (rig.own_lines) rig.lines = rig.own_lines.get();

  const hal::DriveLimits hw = rig.drive->limits();
  check_drive_hardware(c, hw.V_min, hw.V_max);
  return rig;
}

SensorRig build_sensor(const RigConfig& c) {
  SensorRig s;
  s.clock = std::make_unique<hal::posix::MonotonicClock>();
  switch (c.sensor.backend) {
    case SensorBackend::sim:
      s.sim = std::make_unique<hal::sim::SimRig>(sim_rig_settings(c), *s.clock, s.clock->now());
      s.sensor = &s.sim->sensor();
      break;
    case SensorBackend::modbus_tcp:
    case SensorBackend::modbus_rtu:
      s.own_sensor = make_modbus_sensor(c, *s.clock);
      s.sensor = s.own_sensor.get();
      break;
  }
  s.checked_sensor = held_to_range(c, *s.sensor);
  s.sensor = s.checked_sensor.get();
  return s;
}

}  // namespace piezo::config
