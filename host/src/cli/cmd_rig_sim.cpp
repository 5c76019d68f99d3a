// `piezo rig-sim`: the simulated rig as a Modbus device, so that the real
// Modbus backends (and any Modbus tool) can be exercised over real links.

#include <fmt/format.h>

#include <cstdlib>
#include <thread>

#include "commands.hpp"
#include "config/config_file.hpp"
#include "piezo/config/config_error.hpp"
#include "piezo/hal/modbus/modbus_backends.hpp"
#include "piezo/hal/sim/modbus_rig_device.hpp"
#include "piezo/hal/sim/sim_backends.hpp"

namespace piezo::host {
namespace {

struct RigSimOptions {
  std::string config;
  std::vector<std::string> sets;
  std::string tcp;  // HOST:PORT
  std::string rtu;  // device
};

std::pair<std::string, int> split_host_port(const std::string& text) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos) throw config::ConfigError("--tcp", text, "expected HOST:PORT");
  try {
    const int port = std::stoi(text.substr(colon + 1));
    if (port < 1 || port > 65535) throw std::out_of_range("port");
    return {text.substr(0, colon), port};
  } catch (const std::logic_error&) {
    throw config::ConfigError("--tcp", text, "port must be a number in [1, 65535]");
  }
}

/// One axis's devices as the board's config names them (the simulated
/// amplifier and laser, the sensor's registers and the analog-output
/// module's).
hal::sim::ModbusRigAxis axis_device(const config::BoardConfig& board, std::size_t i) {
  const config::AxisConfig& a = board.axes[i];
  hal::sim::ModbusRigAxis s;
  s.name = a.name;
  s.plant = a.plant;
  const hal::DriveCommon drive = board.drive_common(i);
  s.amplifier = a.drive.backends.get<hal::sim::SimDriveBackend>().amplifier(drive);
  s.sensor = a.sensor.backends.get<hal::sim::SimSensorBackend>().settings(board.sensor_common(i));
  s.sensor_map = a.sensor.backends.get<hal::modbus::ModbusSensorBackend>().map();
  const auto ao = a.drive.backends.get<hal::modbus::AnalogOutputBackend>().settings(drive);
  s.ao_address = ao.address;
  s.ao_counts_per_V = ao.counts_per_V;
  s.coupling = a.plant_coupling;
  return s;
}

/// Where a key of axis `i` is, as the config's reader names it.
std::string axis_key(const config::BoardConfig& board, std::size_t i, const std::string& key) {
  return board.axes.size() > 1 ? fmt::format("axes.{}.{}", board.axes[i].name, key) : key;
}

/// rig-sim is one device on one link: every axis's sensor on that link and
/// (on RTU) one unit, and no register of one axis at another's.
void check_one_device(const config::BoardConfig& board,
                      const std::vector<hal::sim::ModbusRigAxis>& axes) {
  const auto link_of = [&](std::size_t i) {
    return board.axes[i].sensor.backends.get<hal::modbus::ModbusSensorBackend>().link();
  };
  for (std::size_t i = 1; i < axes.size(); ++i) {
    if (link_of(i).describe() != link_of(0).describe()) {
      throw config::ConfigError(
          board.source, axis_key(board, i, "sensor.modbus"),
          fmt::format("on {}, {}'s on {}: rig-sim is one device on one link", link_of(i).describe(),
                      axis_key(board, 0, "sensor.modbus"), link_of(0).describe()));
    }
    if (link_of(0).transport == hal::modbus::LinkSettings::Transport::rtu &&
        axes[i].sensor_map.unit_id != axes[0].sensor_map.unit_id) {
      throw config::ConfigError(
          board.source, axis_key(board, i, "sensor.modbus.unit_id"),
          fmt::format("{}, {}'s {}: rig-sim answers one unit on an RTU line",
                      axes[i].sensor_map.unit_id, axis_key(board, 0, "sensor.modbus.unit_id"),
                      axes[0].sensor_map.unit_id));
    }
  }
  // Every register an axis uses, with the key that places it.
  struct Use {
    bool input;
    int first, last;
    std::string key;
  };
  std::vector<Use> uses;
  for (std::size_t i = 0; i < axes.size(); ++i) {
    const auto& m = axes[i].sensor_map;
    uses.push_back({m.function == hal::modbus::Function::input, m.address,
                    m.address + hal::modbus::word_count(m.type) - 1,
                    axis_key(board, i, "sensor.modbus.address")});
    uses.push_back({false, axes[i].ao_address, axes[i].ao_address,
                    axis_key(board, i, "drive.modbus-ao.address")});
  }
  for (std::size_t i = 0; i < uses.size(); ++i) {
    for (std::size_t j = i + 1; j < uses.size(); ++j) {
      const Use &a = uses[i], &b = uses[j];
      if (a.input != b.input || a.last < b.first || b.last < a.first) continue;
      throw config::ConfigError(
          board.source, b.key,
          fmt::format("{} register {} is also {}'s: each axis needs registers of its own",
                      b.input ? "input" : "holding", b.first, a.key));
    }
  }
}

hal::sim::ModbusRigDeviceSettings device_settings(const config::BoardConfig& board,
                                                  const config::RigSimConfig& own) {
  hal::sim::ModbusRigDeviceSettings s;
  s.axes.clear();
  for (std::size_t i = 0; i < board.axes.size(); ++i) s.axes.push_back(axis_device(board, i));
  check_one_device(board, s.axes);
  s.serial = board.axis().sensor.backends.get<hal::modbus::ModbusSensorBackend>().link();
  s.faults = own.faults;
  s.tcp = own.tcp;
  return s;
}

int run(const RigSimOptions& o) {
  const config::ConfigFile config =
      config::load_config_file(o.config, o.sets, config::ConfigScope::sensor);
  const auto& serial =
      config.board.axis().sensor.backends.get<hal::modbus::ModbusSensorBackend>().link();
  std::string tcp = o.tcp;
  if (tcp.empty() && o.rtu.empty()) tcp = serial.host + ":" + std::to_string(serial.port);
  hal::sim::ModbusRigDevice server(device_settings(config.board, config.rig_sim));
  fmt::print("rig-sim: {}\n", server.describe());
  std::thread rtu_thread;
  if (!o.rtu.empty()) {
    fmt::print("rig-sim: serving RTU on {} ({} {}{}{})\n", o.rtu, serial.baud, serial.data_bits,
               serial.parity, serial.stop_bits);
    if (tcp.empty()) {
      std::fflush(stdout);
      server.serve_rtu(o.rtu);
    }
    rtu_thread = std::thread([&] {
      try {
        server.serve_rtu(o.rtu);
      } catch (const std::exception& e) {
        fmt::print(stderr, "piezo: error: {}\n", e.what());
        std::exit(1);
      }
    });
  }
  const auto [host, port] = split_host_port(tcp);
  fmt::print("rig-sim: listening on tcp {}:{}\n", host, port);
  std::fflush(stdout);
  server.serve_tcp(host, port);
  return 0;
}

}  // namespace

void add_rig_sim_command(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<RigSimOptions>();
  CLI::App* cmd = app.add_subcommand("rig-sim", "Serve the simulated rig as a Modbus device");
  add_config_option(*cmd, o->config,
                    "Rig config: [plant], [sensor] map, [drive] ao_*, [rig_sim]; each of its "
                    "[axes] an axis of the device")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--set", o->sets, "Override a config key: SECTION.KEY=VALUE");
  cmd->add_option("--tcp", o->tcp, "Listen on HOST:PORT (default: [sensor] host and port)");
  cmd->add_option("--rtu", o->rtu, "Serve RTU on this serial device or pseudo-terminal");
  commands.add(cmd, [o] { return run(*o); });
}

}  // namespace piezo::host
