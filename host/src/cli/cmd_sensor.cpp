// `piezo sensor read`: polls the configured displacement sensor — the first
// thing to run when wiring a new sensor.

#include <fmt/format.h>

#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "rig.hpp"
#include "run_config.hpp"

namespace piezo::host {
namespace {

struct SensorReadOptions {
  std::string config;
  std::vector<std::string> sets;
  int count = 10;
  bool json = false;
};

int run(const SensorReadOptions& o) {
  const config::RunConfig config =
      config::load_run_config(o.config, o.sets, config::ConfigScope::sensor);
  config::SensorRig rig = config::build_sensor(config);
  hal::Clock& clock = *rig.clock;
  const auto period = hal::from_seconds(1.0 / config.sensor.rate_hz());
  const hal::TimeNs t0 = clock.now();
  nlohmann::json readings = nlohmann::json::array();
  int errors = 0;
  hal::TimeNs deadline = t0;
  for (int i = 0; i < o.count; ++i) {
    clock.sleep_until(deadline);
    const hal::DisplacementReading r = rig.sensor->read();
    const bool ok = r.status == hal::Status::ok;
    errors += ok ? 0 : 1;
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
    std::cout << nlohmann::json{{"readings", readings}, {"errors", errors}}.dump() << "\n";
  } else {
    fmt::print("{} readings, {} errors ({} sensor, {})\n", o.count, errors,
               name(config.sensor.backend),
               config.sensor.backend == config::SensorBackend::sim ? "simulated"
                                                                   : config.sensor.link.describe());
  }
  return errors == o.count ? 1 : 0;
}

}  // namespace

CommandRunner add_sensor_command(CLI::App& app) {
  auto o = std::make_shared<SensorReadOptions>();
  CLI::App* sensor = app.add_subcommand("sensor", "Work with the displacement sensor");
  sensor->require_subcommand(1);
  CLI::App* read = sensor->add_subcommand("read", "Poll the configured sensor and print readings");
  read->add_option("--config", o->config, "Rig config (TOML) with a [sensor] section")
      ->required()
      ->check(CLI::ExistingFile);
  read->add_option("--set", o->sets, "Override a config key: sensor.KEY=VALUE");
  read->add_option("--count", o->count, "Readings to take")->check(CLI::Range(1, 1'000'000));
  read->add_flag("--json", o->json, "Print one JSON object on stdout");
  return [o, read]() { return read->parsed() ? run(*o) : -1; };
}

}  // namespace piezo::host
