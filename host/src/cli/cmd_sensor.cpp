// `piezo sensor read`: polls an axis's configured displacement sensor — the
// first thing to run when wiring a new sensor; `piezo sensor list`: what the
// configured devices offer (a DAQ card's subdevices, channels and ranges).

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <iostream>
#include <nlohmann/json.hpp>
#include <utility>

#include "commands.hpp"
#include "config/config_file.hpp"
#include "config/device_inventory.hpp"
#include "config/rig.hpp"
#include "piezo/hal/modbus/modbus_sensor.hpp"

namespace piezo::host {
namespace {

/// A distance the sensor could have measured: finite, inside the measuring
/// range, and not a subnormal speck (a 32-bit value read in the wrong word
/// order comes out enormous or as one).
bool plausible(double m, const config::SensorSettings& s) {
  return std::isfinite(m) && m >= s.range_min_m && m <= s.range_max_m &&
         (m == 0.0 || std::abs(m) >= 1e-9);
}

/// When the configured word order makes the registers implausible and
/// another order reads them as a plausible distance: a warning naming it.
std::string word_order_hint(const hal::modbus::ModbusSensor& sensor,
                            const config::SensorSettings& s) {
  namespace mb = hal::modbus;
  const mb::RegisterMap& map = sensor.map();
  if (mb::word_count(map.type) != 2) return {};
  const auto& words = sensor.last_words();
  const auto metres = [&](mb::WordOrder order) {
    return mb::decode(map.type, order, words) * map.scale + map.offset;
  };
  if (plausible(metres(map.order), s)) return {};
  constexpr std::array<std::pair<mb::WordOrder, const char*>, 4> kOrders{
      {{mb::WordOrder::ABCD, "ABCD"},
       {mb::WordOrder::CDAB, "CDAB"},
       {mb::WordOrder::BADC, "BADC"},
       {mb::WordOrder::DCBA, "DCBA"}}};
  std::string configured, better;
  for (const auto& [order, name] : kOrders) {
    if (order == map.order) configured = name;
    if (order != map.order && plausible(metres(order), s)) {
      better += fmt::format("{}in {} they read {:.7g} m", better.empty() ? "" : "; ", name,
                            metres(order));
    }
  }
  if (better.empty()) return {};
  return fmt::format(
      "with sensor.modbus.word_order = {} the registers 0x{:04X} 0x{:04X} read {:.4g} m, not a "
      "distance "
      "in [{:g}, {:g}] m; {}: check sensor.modbus.word_order (and the preset)",
      configured, words[0], words[1], metres(map.order), s.range_min_m, s.range_max_m, better);
}

struct SensorReadOptions {
  std::string config;
  std::string axis;
  std::vector<std::string> sets;
  int count = 10;
  bool json = false;
};

int run(const SensorReadOptions& o) {
  const config::ConfigFile config =
      config::load_config_file(o.config, o.sets, config::ConfigScope::sensor);
  const std::size_t axis = config.board.axis_index(o.axis, "--axis");
  const config::SensorSettings& settings = config.board.axis(axis).sensor;
  config::SensorRig rig = config::build_sensor(config.board, axis);
  hal::Clock& clock = *rig.clock;
  const auto period = hal::from_seconds(1.0 / config.board.sensor_rate_hz);
  const hal::TimeNs t0 = clock.now();
  nlohmann::json readings = nlohmann::json::array();
  int errors = 0;
  const auto* modbus = dynamic_cast<const hal::modbus::ModbusSensor*>(rig.own_sensor.get());
  std::string warning;
  hal::TimeNs deadline = t0;
  for (int i = 0; i < o.count; ++i) {
    clock.sleep_until(deadline);
    const hal::DisplacementReading r = rig.sensor->read();
    const bool ok = r.status == hal::Status::ok;
    errors += ok ? 0 : 1;
    if (modbus != nullptr && warning.empty() &&
        (r.status == hal::Status::ok || r.status == hal::Status::out_of_range ||
         r.status == hal::Status::invalid_reading)) {
      warning = word_order_hint(*modbus, settings);
      if (!warning.empty()) std::cerr << "piezo sensor read: warning: " << warning << "\n";
    }
    const double t = hal::to_seconds(r.t_request - t0);
    const double latency_ms = 1e3 * hal::to_seconds(r.t_response - r.t_request);
    if (o.json) {
      readings.push_back({{"t", t},
                          {"displacement_m", ok ? nlohmann::json(r.displacement_m) : nullptr},
                          {"status", std::string(hal::to_string(r.status))},
                          {"latency_ms", latency_ms}});
    } else if (ok) {
      fmt::print("{:8.4f} s  {:.6f} mm  ({:.2f} ms)\n", t, 1e3 * r.displacement_m, latency_ms);
    } else {
      fmt::print("{:8.4f} s  {}  ({:.2f} ms)\n", t, hal::to_string(r.status), latency_ms);
    }
    deadline = std::max(deadline + period, clock.now());
  }
  if (o.json) {
    nlohmann::json j{{"readings", readings}, {"errors", errors}};
    if (!warning.empty()) j["warning"] = warning;
    std::cout << j.dump() << "\n";
  } else {
    fmt::print("{} readings, {} errors (axis {}: {} sensor, {})\n", o.count, errors,
               config.board.axis(axis).name, settings.backend(),
               settings.backends.chosen().describe());
  }
  return errors == o.count ? 1 : 0;
}

}  // namespace

/// `piezo sensor list`: what the configured drive and sensor devices offer.
int list(const SensorReadOptions& o) {
  fmt::print("{}",
             config::device_inventory(config::load_config_file(o.config, o.sets).board, false));
  return 0;
}

void add_sensor_command(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<SensorReadOptions>();
  CLI::App* sensor = app.add_subcommand("sensor", "Work with the displacement sensor");
  sensor->require_subcommand(1);
  CLI::App* read = sensor->add_subcommand("read", "Poll the configured sensor and print readings");
  add_config_option(*read, o->config, "Rig config (TOML) with a [sensor] section")
      ->required()
      ->check(CLI::ExistingFile);
  read->add_option("--set", o->sets, "Override a config key: sensor.KEY=VALUE");
  read->add_option("--axis", o->axis,
                   "The axis whose sensor to read, by name (required when the config has "
                   "several axes)");
  read->add_option("--count", o->count, "Readings to take")->check(CLI::Range(1, 1'000'000));
  add_json_flag(*read, o->json);
  CLI::App* list_devices = sensor->add_subcommand(
      "list",
      "List what the configured drive and sensor devices offer (a DAQ card's "
      "subdevices, channels and ranges), to check the wiring before driving");
  add_config_option(*list_devices, o->config, "Rig config (TOML)")
      ->required()
      ->check(CLI::ExistingFile);
  list_devices->add_option("--set", o->sets, "Override a config key: SECTION.KEY=VALUE");
  commands.add(read, [o] { return run(*o); });
  commands.add(list_devices, [o] { return list(*o); });
}

}  // namespace piezo::host
