#pragma once
// The Modbus keys of a rig config: the sensor's link and register map in
// [sensor] (with presets for known sensors), the analog-output module's in
// [drive].

#include <string>
#include <vector>

#include "piezo/hal/modbus/link.hpp"
#include "piezo/hal/modbus/modbus_analog_output.hpp"
#include "piezo/hal/modbus/register_map.hpp"
#include "section_reader.hpp"

namespace piezo::host {

inline const std::vector<std::string> kModbusSensorKeys{
    "host",          "port",       "device",  "baud",   "parity",   "data_bits",
    "stop_bits",     "rs485",      "unit_id", "preset", "function", "address",
    "type",          "word_order", "scale",   "offset", "range_mm", "response_timeout_s",
    "byte_timeout_s"};
inline const std::vector<std::string> kModbusDriveKeys{
    "ao_host",         "ao_port",         "ao_unit_id",  "ao_address",
    "ao_counts_per_V", "ao_full_scale_V", "ao_timeout_s"};

/// The Baumer OM20/OM30 map: FC04, register 202, f32 CDAB in millimetres, 57600 8E1, unit 1.
void apply_baumer_om30(hal::modbus::LinkSettings& link, hal::modbus::RegisterMap& map);

/// Reads `preset` first, then the link and map keys of [sensor] over it.
void read_modbus_sensor(SectionReader& r, hal::modbus::LinkSettings& link,
                        hal::modbus::RegisterMap& map);
/// Reads the ao_* keys of [drive].
void read_modbus_drive(SectionReader& r, hal::modbus::LinkSettings& link,
                       hal::modbus::AnalogOutputSettings& ao);

}  // namespace piezo::host
