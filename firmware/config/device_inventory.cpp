#include "device_inventory.hpp"

#include <fmt/format.h>

namespace piezo::config {
namespace {

std::string block(const std::string& kind, const std::string& backend, const std::string& text) {
  return fmt::format("{} ({}): {}{}", kind, backend, text, text.ends_with('\n') ? "" : "\n");
}

}  // namespace

std::string device_inventory(const BoardConfig& config, bool with_lines) {
  std::string out;
  for (const AxisConfig& a : config.axes) {
    // An axis's name heads its devices when the board has several.
    const std::string axis = config.axes.size() > 1 ? a.name + " " : "";
    const std::string drive = a.drive.backends.chosen().inventory();
    const std::string sensor = a.sensor.backends.chosen().inventory();
    out += block(axis + "drive", a.drive.backend(), drive);
    out += sensor == drive
               ? fmt::format("{}sensor ({}): the same device\n", axis, a.sensor.backend())
               : block(axis + "sensor", a.sensor.backend(), sensor);
  }
  if (with_lines) {
    out += block("lines", config.lines.backend(), config.lines.backends.chosen().inventory());
  }
  return out;
}

}  // namespace piezo::config
