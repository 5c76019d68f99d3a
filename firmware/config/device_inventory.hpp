#pragma once
// What the configured devices offer (a card's subdevices, channels and
// ranges; a GPIO chip's lines; a Modbus link), as `piezo sensor list` and
// `piezod devices` print it, so that a researcher can check the wiring
// against the config before anything is driven. Nothing is opened for
// writing: each backend's inventory only asks its device.

#include <string>

#include "config_file.hpp"

namespace piezo::config {

/// One block per kind (drive, sensor, lines), each "KIND (BACKEND): ..."; a
/// device that serves two kinds is listed once.
[[nodiscard]] std::string device_inventory(const BoardConfig& config, bool with_lines);

}  // namespace piezo::config
