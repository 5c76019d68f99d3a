#include "piezo/hal/modbus/modbus_sensor.hpp"

#include <array>
#include <cmath>

namespace piezo::hal::modbus {

ModbusSensor::ModbusSensor(const LinkSettings& link, const RegisterMap& map, const Clock& clock)
    : link_(link.transport == LinkSettings::Transport::rtu ? Link::on_serial_line(link)
                                                           : std::make_shared<Link>(link)),
      shared_line_(link.transport == LinkSettings::Transport::rtu ? "modbus " + link.describe()
                                                                  : std::string()),
      map_(map),
      clock_(clock) {}

DisplacementReading ModbusSensor::read() {
  std::array<std::uint16_t, 2>& words = last_words_;
  words = {};
  DisplacementReading r;
  r.t_request = clock_.now();
  r.status =
      link_->read(map_.function, map_.unit_id, map_.address, word_count(map_.type), words.data());
  r.t_response = clock_.now();
  if (r.status == Status::ok) {
    r.displacement_m = to_metres(map_, words);
    // Sensors report "no target" as NaN or infinity in their float registers.
    if (!std::isfinite(r.displacement_m)) r.status = Status::invalid_reading;
  }
  return r;
}

}  // namespace piezo::hal::modbus
