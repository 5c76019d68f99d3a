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

namespace piezo::config {

/// How a Modbus analog output is guarded against a dead link.
struct AnalogOutputGuard {
  double watchdog_s = 0.0;              ///< the module watchdog's timeout (0: none configured)
  bool link_loss_acknowledged = false;  ///< the config accepts a module that holds its value
};

/// The Baumer OM20/OM30 map: FC04, register 202, f32 CDAB in millimetres, 57600 8E1, unit 1.
void apply_baumer_om30(hal::modbus::LinkSettings& link, hal::modbus::RegisterMap& map);

/// Reads `preset` first, then the link and map keys of [sensor] over it.
void read_modbus_sensor(SectionReader& r, hal::modbus::LinkSettings& link,
                        hal::modbus::RegisterMap& map);
/// Reads the ao_* keys of [drive].
void read_modbus_drive(SectionReader& r, hal::modbus::LinkSettings& link,
                       hal::modbus::AnalogOutputSettings& ao, AnalogOutputGuard& guard);

}  // namespace piezo::config
