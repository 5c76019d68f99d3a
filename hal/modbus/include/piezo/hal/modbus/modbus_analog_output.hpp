#pragma once
/// @file
/// The drive through a Modbus analog-output module (a remote I/O module's
/// holding register) feeding the piezo amplifier's input.

#include "piezo/hal/drive.hpp"
#include "piezo/hal/modbus/link.hpp"

namespace piezo::hal::modbus {

struct AnalogOutputSettings {
  int unit_id = 1;
  int address = 0;               ///< holding register of the output channel
  double counts_per_V = 1000.0;  ///< register counts per volt at the module's output
  double full_scale_V = 10.0;    ///< the module's highest output [V]
  double amplifier_gain = 20.0;  ///< amplifier output volts per input volt
};

class ModbusAnalogOutput final : public Drive {
 public:
  ModbusAnalogOutput(const LinkSettings& link, const AnalogOutputSettings& settings);

  /// Writes the register for amplifier output `volts`: one round trip.
  Status write(double volts) override;
  [[nodiscard]] DriveLimits limits() const override;

 private:
  Link link_;
  AnalogOutputSettings settings_;
};

}  // namespace piezo::hal::modbus
