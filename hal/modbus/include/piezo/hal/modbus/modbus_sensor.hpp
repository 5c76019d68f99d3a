#pragma once
/// @file
/// A laser displacement sensor read over Modbus (RTU or TCP) with a
/// register map from config.

#include <memory>

#include "piezo/hal/clock.hpp"
#include "piezo/hal/displacement_sensor.hpp"
#include "piezo/hal/modbus/link.hpp"
#include "piezo/hal/modbus/register_map.hpp"

namespace piezo::hal::modbus {

class ModbusSensor final : public DisplacementSensor {
 public:
  ModbusSensor(const LinkSettings& link, const RegisterMap& map, const Clock& clock);

  [[nodiscard]] DisplacementReading read() override;

 private:
  Link link_;
  RegisterMap map_;
  const Clock& clock_;
};

}  // namespace piezo::hal::modbus
