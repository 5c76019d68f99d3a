#include "rig.hpp"

#include "piezo/hal/gpio/gpio_digital_lines.hpp"
#include "piezo/hal/gpio/parallel_dac.hpp"
#include "piezo/hal/gpiod/gpiod_lines.hpp"
#include "piezo/hal/modbus/modbus_analog_output.hpp"
#include "piezo/hal/modbus/modbus_sensor.hpp"
#include "piezo/hal/posix/monotonic_clock.hpp"
#include "piezo/hal/posix/no_lines.hpp"
#include "piezo/hal/sim/plant.hpp"
#include "piezo/hal/sim/sim_drive.hpp"
#include "piezo/hal/sim/sim_lines.hpp"
#include "piezo/hal/sim/sim_sensor.hpp"
#include "piezo/hal/sim/virtual_clock.hpp"

namespace piezo::config {
namespace {

std::unique_ptr<hal::Clock> make_clock(const RunConfig& c) {
  if (c.virtual_clock()) return std::make_unique<hal::sim::VirtualClock>();
  return std::make_unique<hal::posix::MonotonicClock>();
}

std::unique_ptr<hal::DisplacementSensor> make_modbus_sensor(const RunConfig& c,
                                                            const hal::Clock& clock) {
  return std::make_unique<hal::modbus::ModbusSensor>(c.sensor.link, c.sensor.map,
                                                     c.sensor.rate_hz(), clock);
}

constexpr const char* kConsumer = "piezo";

std::vector<unsigned> offsets(std::initializer_list<int> list) {
  std::vector<unsigned> out;
  for (int o : list)
    if (o >= 0) out.push_back(static_cast<unsigned>(o));
  return out;
}

std::unique_ptr<hal::Drive> make_gpio_dac(const GpioDacSettings& g, Rig& rig) {
  std::vector<unsigned> lines(g.data_offsets.begin(), g.data_offsets.end());
  if (g.strobe_offset >= 0) lines.push_back(static_cast<unsigned>(g.strobe_offset));
  // Requested at code 0 and strobe idle: never a moment at full scale.
  auto group = std::make_shared<hal::gpiod::GpiodOutputs>(
      g.chip, lines, hal::gpio::ParallelDac::idle_levels(g.dac), kConsumer);
  rig.parts.push_back(group);
  return std::make_unique<hal::gpio::ParallelDac>(g.dac, *group);
}

std::unique_ptr<hal::DigitalLines> make_gpio_lines(const LinesSettings& l, Rig& rig) {
  // Requested with the amplifier disabled, whatever the polarity.
  auto outputs = std::make_shared<hal::gpiod::GpiodOutputs>(
      l.chip, offsets({l.enable_offset, l.sync_offset}),
      hal::gpio::GpioDigitalLines::idle_levels(l.gpio), kConsumer);
  rig.parts.push_back(outputs);
  hal::InputLine* estop = nullptr;
  if (l.estop_offset >= 0) {
    auto input = std::make_shared<hal::gpiod::GpiodEdgeInput>(
        l.chip, static_cast<unsigned>(l.estop_offset), kConsumer);
    rig.parts.push_back(input);
    estop = input.get();
  }
  return std::make_unique<hal::gpio::GpioDigitalLines>(l.gpio, *outputs, estop);
}

}  // namespace

Rig build_rig(const RunConfig& c) {
  Rig rig;
  rig.clock = make_clock(c);
  rig.t0 = rig.clock->now();

  // The simulated drive, sensor and lines share one plant (the config
  // checks that "sim" backends come together).
  std::shared_ptr<hal::sim::Plant> plant;
  if (c.drive.backend == DriveBackend::sim) {
    plant = std::make_shared<hal::sim::Plant>(c.plant, c.drive.amplifier, rig.clock->now());
    auto drive = std::make_unique<hal::sim::SimDrive>(c.drive.dac, *plant, *rig.clock, rig.t0);
    auto sensor = std::make_unique<hal::sim::SimSensor>(c.sensor.sim, *plant, *rig.clock, rig.t0);
    rig.on_start.emplace_back([d = drive.get()](hal::TimeNs t0) { d->set_time_origin(t0); });
    rig.on_start.emplace_back([s = sensor.get()](hal::TimeNs t0) { s->set_time_origin(t0); });
    rig.drive = std::move(drive);
    rig.sensor = std::move(sensor);
    rig.parts.push_back(plant);
  } else {
    rig.drive = c.drive.backend == DriveBackend::gpiod_dac ? make_gpio_dac(c.drive.gpio_dac, rig)
                                               : std::make_unique<hal::modbus::ModbusAnalogOutput>(
                                                     c.drive.ao_link, c.drive.ao);
    rig.sensor = make_modbus_sensor(c, *rig.clock);
  }
  if (c.lines.backend == LinesBackend::sim) {
    auto lines = std::make_unique<hal::sim::SimLines>(c.lines.sim, *plant, *rig.clock, rig.t0);
    rig.on_start.emplace_back([l = lines.get()](hal::TimeNs t0) { l->set_time_origin(t0); });
    rig.lines = std::move(lines);
  } else if (c.lines.backend == LinesBackend::gpiod) {
    rig.lines = make_gpio_lines(c.lines, rig);
  } else {
    rig.lines = std::make_unique<hal::posix::NoLines>();
  }

  const hal::DriveLimits hw = rig.drive->limits();
  check_drive_hardware(c, hw.V_min, hw.V_max);
  return rig;
}

SensorRig build_sensor(const RunConfig& c) {
  SensorRig s;
  s.clock = std::make_unique<hal::posix::MonotonicClock>();
  if (c.sensor.backend == SensorBackend::sim) {
    auto plant = std::make_shared<hal::sim::Plant>(c.plant, c.drive.amplifier, s.clock->now());
    s.sensor =
        std::make_unique<hal::sim::SimSensor>(c.sensor.sim, *plant, *s.clock, s.clock->now());
    s.parts.push_back(plant);
  } else {
    s.sensor = make_modbus_sensor(c, *s.clock);
  }
  return s;
}

}  // namespace piezo::config
