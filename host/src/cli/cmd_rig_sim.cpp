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

/// The devices the board's config names (the simulated amplifier and laser,
/// the sensor's registers and the analog-output module's), with rig-sim's
/// own faults and limits.
hal::sim::ModbusRigDeviceSettings device_settings(const config::BoardConfig& board,
                                                  const config::RigSimConfig& own) {
  hal::sim::ModbusRigDeviceSettings s;
  const config::AxisConfig& a = board.axis();
  s.plant = a.plant;
  const hal::DriveCommon drive = board.drive_common();
  s.amplifier = a.drive.backends.get<hal::sim::SimDriveBackend>().amplifier(drive);
  s.sensor = a.sensor.backends.get<hal::sim::SimSensorBackend>().settings(a.sensor.common());
  const auto& sensor = a.sensor.backends.get<hal::modbus::ModbusSensorBackend>();
  s.sensor_map = sensor.map();
  s.serial = sensor.link();
  const auto ao = a.drive.backends.get<hal::modbus::AnalogOutputBackend>().settings(drive);
  s.ao_address = ao.address;
  s.ao_counts_per_V = ao.counts_per_V;
  s.faults = own.faults;
  s.tcp = own.tcp;
  return s;
}

int run(const RigSimOptions& o) {
  const config::ConfigFile config =
      config::load_config_file(o.config, o.sets, config::ConfigScope::sensor);
  if (config.board.axes.size() > 1) {
    throw config::ConfigError(
        config.source, "axes",
        fmt::format("rig-sim serves one axis; this config declares {}", config.board.axes.size()));
  }
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
  add_config_option(*cmd, o->config, "Rig config: [plant], [sensor] map, [drive] ao_*, [rig_sim]")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--set", o->sets, "Override a config key: SECTION.KEY=VALUE");
  cmd->add_option("--tcp", o->tcp, "Listen on HOST:PORT (default: [sensor] host and port)");
  cmd->add_option("--rtu", o->rtu, "Serve RTU on this serial device or pseudo-terminal");
  commands.add(cmd, [o] { return run(*o); });
}

}  // namespace piezo::host
