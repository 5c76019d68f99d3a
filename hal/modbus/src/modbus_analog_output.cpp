#include "piezo/hal/modbus/modbus_analog_output.hpp"

#include <cmath>

namespace piezo::hal::modbus {

ModbusAnalogOutput::ModbusAnalogOutput(const LinkSettings& link,
                                       const AnalogOutputSettings& settings)
    : link_(link), settings_(settings) {}

DriveLimits ModbusAnalogOutput::limits() const {
  return {0.0, settings_.full_scale_V * settings_.amplifier_gain};
}

Status ModbusAnalogOutput::write(double volts) {
  const double V_in = volts / settings_.amplifier_gain;
  if (!(V_in >= 0.0 && V_in <= settings_.full_scale_V * (1.0 + 1e-12))) return Status::out_of_range;
  const auto counts = static_cast<std::uint16_t>(std::lround(V_in * settings_.counts_per_V));
  return link_.write(settings_.unit_id, settings_.address, counts);
}

}  // namespace piezo::hal::modbus
