#include "modbus_config.hpp"

#include <fmt/format.h>

#include "config_error.hpp"

namespace piezo::config {
namespace {

using hal::modbus::Function;
using hal::modbus::LinkSettings;
using hal::modbus::RegisterMap;
using hal::modbus::RegisterType;
using hal::modbus::WordOrder;

constexpr double kRiftekCounts = 16384.0;  // RF602: X = D * range / 16384

}  // namespace

void apply_baumer_om30(LinkSettings& link, RegisterMap& map) {
  map = {Function::input, 202, RegisterType::f32, WordOrder::CDAB, 1e-3, 0.0, 1};
  link.baud = 57600;
  link.parity = 'E';
  link.data_bits = 8;
  link.stop_bits = 1;
}

void read_modbus_sensor(SectionReader& r, LinkSettings& link, RegisterMap& map) {
  std::string preset;
  r.choice("preset", preset, {"baumer-om30", "riftek-rf602"});
  double range_mm = 10.0;
  r.number("range_mm", range_mm, {0.0, 10'000.0, true}, "mm");
  if (preset == "baumer-om30") apply_baumer_om30(link, map);
  if (preset == "riftek-rf602") {
    map = {Function::input,
           0,
           RegisterType::s16,
           WordOrder::ABCD,
           range_mm * 1e-3 / kRiftekCounts,
           0.0,
           1};
  }
  r.text("host", link.host);
  r.integer("port", link.port, 1, 65535);
  r.text("device", link.device);
  r.integer("baud", link.baud, 300, 4'000'000);
  std::string parity;
  r.choice("parity", parity, {"N", "E", "O"});
  if (!parity.empty()) link.parity = parity[0];
  r.integer("data_bits", link.data_bits, 7, 8);
  r.integer("stop_bits", link.stop_bits, 1, 2);
  r.flag("rs485", link.rs485);
  r.number("response_timeout_s", link.response_timeout_s, {0.001, 10.0}, "s");
  r.number("byte_timeout_s", link.byte_timeout_s, {0.0001, 1.0}, "s");
  r.integer("unit_id", map.unit_id, 0, 247);
  r.choice("function", map.function, hal::modbus::kFunctionNames);
  r.integer("address", map.address, 0, 65535);
  r.choice("type", map.type, hal::modbus::kRegisterTypeNames);
  r.choice("word_order", map.order, hal::modbus::kWordOrderNames);
  r.number("scale", map.scale, {-1e6, 1e6}, "m per raw unit");
  r.number("offset", map.offset, {-1e3, 1e3}, "m");
}

void read_modbus_drive(SectionReader& r, LinkSettings& link, hal::modbus::AnalogOutputSettings& ao,
                       AnalogOutputGuard& guard) {
  r.text("ao_host", link.host);
  r.integer("ao_port", link.port, 1, 65535);
  r.integer("ao_unit_id", ao.unit_id, 0, 247);
  r.integer("ao_address", ao.address, 0, 65535);
  r.number("ao_counts_per_V", ao.counts_per_V, {0.0, 1e6, true}, "counts/V");
  r.number("ao_full_scale_V", ao.full_scale_V, {0.0, 100.0, true}, "V");
  r.number("ao_timeout_s", link.response_timeout_s, {0.001, 10.0}, "s");
  // The module's own watchdog: registers and values from its manual.
  std::vector<int> registers, values;
  r.integer_list("ao_watchdog_registers", registers, 0, 65535);
  r.integer_list("ao_watchdog_values", values, 0, 65535);
  if (registers.size() != values.size()) {
    throw ConfigError(r.source(), r.name("ao_watchdog_values"),
                      fmt::format("{} values for {} ao_watchdog_registers; allowed: one value per "
                                  "register",
                                  values.size(), registers.size()));
  }
  if (!registers.empty() || r.has("ao_watchdog_s")) {
    ao.watchdog_writes.clear();
    for (std::size_t i = 0; i < registers.size(); ++i) {
      ao.watchdog_writes.emplace_back(registers[i], values[i]);
    }
  }
  r.number("ao_watchdog_s", guard.watchdog_s, {0.0, 60.0}, "s");
  r.flag("ao_link_loss_acknowledged", guard.link_loss_acknowledged);
}

}  // namespace piezo::config
