#include "device_inventory.hpp"

#include <fmt/format.h>

namespace piezo::config {
namespace {

std::string block(const std::string& kind, const std::string& backend, const std::string& text) {
  return fmt::format("{} ({}): {}{}", kind, backend, text, text.ends_with('\n') ? "" : "\n");
}

}  // namespace

std::string device_inventory(const BoardConfig& config, bool with_lines) {
  const std::string drive = config.drive.backends.chosen().inventory();
  const std::string sensor = config.sensor.backends.chosen().inventory();
  std::string out = block("drive", config.drive.backend(), drive);
  out += sensor == drive ? fmt::format("sensor ({}): the same device\n", config.sensor.backend())
                         : block("sensor", config.sensor.backend(), sensor);
  if (with_lines) {
    out += block("lines", config.lines.backend(), config.lines.backends.chosen().inventory());
  }
  return out;
}

}  // namespace piezo::config
