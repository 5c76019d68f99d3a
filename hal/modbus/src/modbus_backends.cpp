#include "piezo/hal/modbus/modbus_backends.hpp"

#include <fmt/format.h>

#include "piezo/config/config_error.hpp"
#include "piezo/hal/modbus/modbus_sensor.hpp"

namespace piezo::hal::modbus {
namespace {

using config::ConfigError;

constexpr double kRiftekCounts = 16384.0;  // RF602: X = D * range / 16384

/// A register on a link (its device or address, not its speed) as a
/// resource two axes must not share.
std::string register_resource(const LinkSettings& link, int unit_id, std::string_view function,
                              int address) {
  const std::string where = link.transport == LinkSettings::Transport::tcp
                                ? fmt::format("tcp {}:{}", link.host, link.port)
                                : "rtu " + link.device;
  return fmt::format("modbus {} unit {} {} register {}", where, unit_id, function, address);
}

}  // namespace

void apply_baumer_om30(LinkSettings& link, RegisterMap& map) {
  map = {Function::input, 202, RegisterType::f32, WordOrder::CDAB, 1e-3, 0.0, 1};
  link.baud = 57600;
  link.parity = 'E';
  link.data_bits = 8;
  link.stop_bits = 1;
}

ModbusSensorBackend::ModbusSensorBackend(LinkSettings::Transport transport) {
  apply_baumer_om30(link_, map_);
  link_.transport = transport;
}

std::string_view ModbusSensorBackend::name() const {
  return link_.transport == LinkSettings::Transport::rtu ? "modbus-rtu" : "modbus-tcp";
}

std::vector<Claim> ModbusSensorBackend::claims() const {
  // Every register the reading takes (an f32 two): a sensor at 203 overlaps one at 202.
  std::vector<Claim> out;
  for (int word = 0; word < word_count(map_.type); ++word) {
    out.push_back({register_resource(link_, map_.unit_id, kFunctionNames.name(map_.function),
                                     map_.address + word),
                   "sensor.modbus.address"});
  }
  return out;
}

std::vector<MovedKey> ModbusSensorBackend::moved_keys() const {
  return {{"preset", "sensor.modbus.preset"},
          {"range_mm", "sensor.modbus.range_mm"},
          {"host", "sensor.modbus.host"},
          {"port", "sensor.modbus.port"},
          {"device", "sensor.modbus.device"},
          {"baud", "sensor.modbus.baud"},
          {"parity", "sensor.modbus.parity"},
          {"data_bits", "sensor.modbus.data_bits"},
          {"stop_bits", "sensor.modbus.stop_bits"},
          {"rs485", "sensor.modbus.rs485"},
          {"response_timeout_s", "sensor.modbus.response_timeout_s"},
          {"byte_timeout_s", "sensor.modbus.byte_timeout_s"},
          {"unit_id", "sensor.modbus.unit_id"},
          {"function", "sensor.modbus.function"},
          {"address", "sensor.modbus.address"},
          {"type", "sensor.modbus.type"},
          {"word_order", "sensor.modbus.word_order"},
          {"scale", "sensor.modbus.scale"},
          {"offset", "sensor.modbus.offset"}};
}

void ModbusSensorBackend::read(config::SectionReader& r) {
  std::string preset;
  r.choice("preset", preset, {"baumer-om30", "riftek-rf602"});
  double range_mm = 10.0;
  r.number("range_mm", range_mm, {0.0, 10'000.0, true}, "mm");
  if (preset == "baumer-om30") apply_baumer_om30(link_, map_);
  if (preset == "riftek-rf602") {
    map_ = {Function::input,
            0,
            RegisterType::s16,
            WordOrder::ABCD,
            range_mm * 1e-3 / kRiftekCounts,
            0.0,
            1};
  }
  r.text("host", link_.host);
  r.integer("port", link_.port, 1, 65535);
  r.text("device", link_.device);
  r.integer("baud", link_.baud, 300, 4'000'000);
  std::string parity(1, link_.parity);
  r.choice("parity", parity, {"N", "E", "O"});
  link_.parity = parity[0];
  r.integer("data_bits", link_.data_bits, 7, 8);
  r.integer("stop_bits", link_.stop_bits, 1, 2);
  r.flag("rs485", link_.rs485);
  r.number("response_timeout_s", link_.response_timeout_s, {0.001, 10.0}, "s");
  r.number("byte_timeout_s", link_.byte_timeout_s, {0.0001, 1.0}, "s");
  r.integer("unit_id", map_.unit_id, 0, 247);
  r.choice("function", map_.function, kFunctionNames);
  r.integer("address", map_.address, 0, 65535);
  r.choice("type", map_.type, kRegisterTypeNames);
  r.choice("word_order", map_.order, kWordOrderNames);
  r.number("scale", map_.scale, {-1e6, 1e6}, "m per raw unit");
  r.number("offset", map_.offset, {-1e3, 1e3}, "m");
}

void ModbusSensorBackend::check(const SensorCommon&, bool chosen, const SourceOf& source) const {
  const int words = word_count(map_.type);
  if (map_.address + words - 1 > 65535) {
    throw ConfigError(source("sensor.modbus.address"), "sensor.modbus.address",
                      fmt::format("{} with a {}-register value runs past register 65535; "
                                  "allowed: 0..{}",
                                  map_.address, words, 65536 - words));
  }
  if (chosen && link_.transport == LinkSettings::Transport::rtu && link_.device.empty()) {
    throw ConfigError(source("sensor.modbus.device"), "sensor.modbus.device",
                      "missing: modbus-rtu needs the serial device, e.g. \"/dev/ttyUSB0\"");
  }
}

std::shared_ptr<DisplacementSensor> ModbusSensorBackend::open(const SensorCommon&,
                                                              OpenContext& context) const {
  return std::make_shared<ModbusSensor>(link_, map_, context.clock);
}

std::vector<Claim> AnalogOutputBackend::claims() const {
  return {
      {register_resource(link_, ao_.unit_id, "holding", ao_.address), "drive.modbus-ao.address"}};
}

std::vector<MovedKey> AnalogOutputBackend::moved_keys() const {
  return {{"ao_host", "drive.modbus-ao.host"},
          {"ao_port", "drive.modbus-ao.port"},
          {"ao_unit_id", "drive.modbus-ao.unit_id"},
          {"ao_address", "drive.modbus-ao.address"},
          {"ao_counts_per_V", "drive.modbus-ao.counts_per_V"},
          {"ao_full_scale_V", "drive.modbus-ao.full_scale_V"},
          {"ao_timeout_s", "drive.modbus-ao.timeout_s"},
          {"ao_watchdog_registers", "drive.modbus-ao.watchdog_registers"},
          {"ao_watchdog_values", "drive.modbus-ao.watchdog_values"},
          {"ao_watchdog_s", "drive.modbus-ao.watchdog_s"},
          {"ao_link_loss_acknowledged", "drive.modbus-ao.link_loss_acknowledged"}};
}

void AnalogOutputBackend::read(config::SectionReader& r) {
  r.text("host", link_.host);
  r.integer("port", link_.port, 1, 65535);
  r.integer("unit_id", ao_.unit_id, 0, 247);
  r.integer("address", ao_.address, 0, 65535);
  r.number("counts_per_V", ao_.counts_per_V, {0.0, 1e6, true}, "counts/V");
  r.number("full_scale_V", ao_.full_scale_V, {0.0, 100.0, true}, "V");
  r.number("timeout_s", link_.response_timeout_s, {0.001, 10.0}, "s");
  // The module's own watchdog: registers and values from its manual.
  std::vector<int> registers, values;
  r.integer_list("watchdog_registers", registers, 0, 65535);
  r.integer_list("watchdog_values", values, 0, 65535);
  if (registers.size() != values.size()) {
    throw ConfigError(r.source(), r.name("watchdog_values"),
                      fmt::format("{} values for {} watchdog_registers; allowed: one value per "
                                  "register",
                                  values.size(), registers.size()));
  }
  if (!registers.empty() || r.has("watchdog_s")) {
    ao_.watchdog_writes.clear();
    for (std::size_t i = 0; i < registers.size(); ++i) {
      ao_.watchdog_writes.emplace_back(registers[i], values[i]);
    }
  }
  r.number("watchdog_s", guard_.watchdog_s, {0.0, 60.0}, "s");
  r.flag("link_loss_acknowledged", guard_.link_loss_acknowledged);
}

void AnalogOutputBackend::check(const DriveCommon& common, bool chosen,
                                const SourceOf& source) const {
  const double full_scale_counts = ao_.counts_per_V * ao_.full_scale_V;
  if (full_scale_counts > ModbusAnalogOutput::kMaxCounts) {
    throw ConfigError(
        source("drive.modbus-ao.counts_per_V"), "drive.modbus-ao.counts_per_V",
        fmt::format("{:g} counts/V x drive.modbus-ao.full_scale_V = {:g} V is {:g} counts, "
                    "beyond the 16-bit register's 65535; allowed: counts_per_V <= {:g}",
                    ao_.counts_per_V, ao_.full_scale_V, full_scale_counts,
                    ModbusAnalogOutput::kMaxCounts / ao_.full_scale_V));
  }
  if (!chosen) return;
  if (!ao_.watchdog_writes.empty() && guard_.watchdog_s <= 0.0) {
    throw ConfigError(source("drive.modbus-ao.watchdog_s"), "drive.modbus-ao.watchdog_s",
                      "missing: the timeout the watchdog_registers set, in seconds; allowed: "
                      "(0, 60]");
  }
  // A module that keeps its output when the link dies cannot be reached by
  // any stop: only its own watchdog or an enable line can end the drive then.
  if (!common.enable_line && ao_.watchdog_writes.empty() && !guard_.link_loss_acknowledged) {
    throw ConfigError(
        source("drive.modbus-ao.watchdog_registers"), "drive.modbus-ao.watchdog_registers",
        "missing: with drive.backend = \"modbus-ao\" and lines.backend = \"none\" nothing can "
        "turn the output off when the Modbus link dies; configure the module's communication "
        "watchdog (watchdog_registers, watchdog_values, watchdog_s in [drive.modbus-ao]), wire "
        "an enable line ([lines] backend = \"gpiod\"), or accept the risk with "
        "drive.modbus-ao.link_loss_acknowledged = true");
  }
}

AnalogOutputSettings AnalogOutputBackend::settings(const DriveCommon& common) const {
  AnalogOutputSettings s = ao_;
  s.amplifier_gain = common.amplifier_gain;
  return s;
}

std::shared_ptr<Drive> AnalogOutputBackend::open(const DriveCommon& common, OpenContext&) const {
  return std::make_shared<ModbusAnalogOutput>(link_, settings(common));
}

}  // namespace piezo::hal::modbus
