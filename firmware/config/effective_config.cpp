#include "effective_config.hpp"

#include <toml++/toml.h>

#include <sstream>

namespace piezo::config {

std::string effective_config_toml(const ConfigFile& file) {
  const BoardConfig& c = file.board;
  const AxisConfig& a = c.axis();  // the host's runs drive the board's first axis
  const HostConfig& h = file.host;
  toml::table drive, motor;
  for (const auto& spec : model::parameter_specs()) {
    const double v = *model::get_parameter(h.model, spec.name);
    (spec.section == "drive" ? drive : motor).insert(std::string(spec.name), v);
  }
  drive.insert("direction", std::string(model::name(h.model.drive.direction)));
  drive.insert("rate_hz", c.drive_rate_hz());
  drive.insert("V_min", a.drive.limits.V_min);
  drive.insert("V_max", a.drive.limits.V_max);
  drive.insert("slew_V_per_s", a.drive.limits.slew_V_per_s);
  const toml::table sensor{{"r2_m", a.sensor.r2_m}, {"rate_hz", c.sensor_rate_hz()}};
  const toml::table run{{"duration_s", h.run.duration_s},
                        {"clock", std::string(name(c.run.clock))}};
  const toml::table observer{{"enabled", h.observer.enabled},
                             {"alpha", h.observer.gains.alpha},
                             {"beta", h.observer.gains.beta},
                             {"gate_rad", h.observer.gains.gate_rad}};
  toml::table out{
      {"drive", drive}, {"model", motor}, {"sensor", sensor}, {"run", run}, {"observer", observer}};
  if (!h.board.address.empty()) {
    out.insert("rig", toml::table{{"address", h.board.address}, {"lease_s", h.board.lease_s}});
  }
  std::ostringstream text;
  text << out << "\n";
  return text.str();
}

std::string run_config_file(const ConfigFile& c) {
  const std::string effective = effective_config_toml(c);
  if (c.text.empty()) {
    return "# What the run used, defaults included (it had no config file of its own).\n" +
           effective;
  }
  std::string out = c.text;
  if (!out.empty() && out.back() != '\n') out += '\n';
  out += "\n# What the run used, defaults included:\n";
  std::istringstream lines(effective);
  for (std::string line; std::getline(lines, line);) out += "#   " + line + "\n";
  return out;
}

}  // namespace piezo::config
