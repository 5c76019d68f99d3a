#include "piezo/hal/modbus/modbus_analog_output.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace piezo::hal::modbus {

ModbusAnalogOutput::ModbusAnalogOutput(const LinkSettings& link,
                                       const AnalogOutputSettings& settings)
    : link_(link), settings_(settings) {
  if (!(settings.counts_per_V * settings.full_scale_V <= kMaxCounts)) {
    throw std::invalid_argument("analog output: counts_per_V x full_scale_V exceeds 65535");
  }
  auto must = [&](Status s, int address, const std::string& what) {
    if (s != Status::ok) {
      throw std::runtime_error("analog output " + link.describe() + ": " + what + " (register " +
                               std::to_string(address) + "): " + std::string(to_string(s)));
    }
  };
  must(write(0.0), settings.address, "cannot write 0 V");
  for (const auto& [address, value] : settings.watchdog_writes) {
    must(link_.write(settings.unit_id, address, static_cast<std::uint16_t>(value)), address,
         "cannot arm the watchdog");
  }
}

DriveLimits ModbusAnalogOutput::limits() const {
  return {0.0, settings_.full_scale_V * settings_.amplifier_gain};
}

std::uint16_t counts_for(const AnalogOutputSettings& settings, double volts) {
  const double counts = std::round(volts / settings.amplifier_gain * settings.counts_per_V);
  return static_cast<std::uint16_t>(std::clamp(counts, 0.0, ModbusAnalogOutput::kMaxCounts));
}

Status ModbusAnalogOutput::write(double volts) {
  const double V_in = volts / settings_.amplifier_gain;
  if (!(V_in >= 0.0 && V_in <= settings_.full_scale_V * (1.0 + 1e-12))) return Status::out_of_range;
  const std::uint16_t counts = counts_for(settings_, volts);
  const Status s = link_.write(settings_.unit_id, settings_.address, counts);
  if (s == Status::ok) {
    acknowledged_V_ = counts / settings_.counts_per_V * settings_.amplifier_gain;
  }
  return s;
}

}  // namespace piezo::hal::modbus
