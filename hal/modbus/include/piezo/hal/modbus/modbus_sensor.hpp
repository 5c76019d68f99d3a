#pragma once
/// @file
/// A laser displacement sensor read over Modbus (RTU or TCP) with a
/// register map from config.

#include <array>
#include <cstdint>
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
  /// An RTU bus (every sensor on it shares one Link); a TCP sensor has a
  /// connection of its own.
  [[nodiscard]] std::string shared_line() const override { return shared_line_; }
  /// The registers of the last read, as they came (for `piezo sensor
  /// read`'s word-order check).
  [[nodiscard]] const std::array<std::uint16_t, 2>& last_words() const { return last_words_; }
  [[nodiscard]] const RegisterMap& map() const { return map_; }

 private:
  std::array<std::uint16_t, 2> last_words_{};
  /// Its own on TCP; on RTU the line's, shared with the other sensors on it.
  std::shared_ptr<Link> link_;
  std::string shared_line_;
  RegisterMap map_;
  const Clock& clock_;
};

}  // namespace piezo::hal::modbus
