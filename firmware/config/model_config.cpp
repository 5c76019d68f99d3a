#include "model_config.hpp"

#include <toml++/toml.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>

#include "config_error.hpp"

namespace piezo::config {
namespace {

double number_from_node(const toml::node& node, const std::string& source, const std::string& key) {
  if (auto v = node.value<double>(); v && (node.is_floating_point() || node.is_integer())) {
    return *v;
  }
  throw ConfigError(source, key, "must be a number");
}

void set_checked(model::Parameters& p, const model::ParameterSpec& spec, double value,
                 const std::string& source, const std::string& key) {
  if (!spec.admits(value)) {
    throw ConfigError(source, key,
                      "value " + std::to_string(value) + " " + std::string(spec.unit) +
                          " is outside the allowed range " + spec.range_text());
  }
  spec.ref(p) = value;
}

}  // namespace

double parse_number(const std::string& text, const std::string& source, const std::string& key) {
  errno = 0;
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE) {
    throw ConfigError(source, key, "'" + text + "' is not a number");
  }
  if (!std::isfinite(value)) throw ConfigError(source, key, "'" + text + "' is not finite");
  return value;
}

void read_model_sections(const toml::table& table, const std::string& source, model::Parameters& p,
                         const std::vector<std::string>& extra_drive_keys) {
  if (const toml::node* drive_node = table.get("drive")) {
    const toml::table* drive = drive_node->as_table();
    if (drive == nullptr) throw ConfigError(source, "drive", "must be a table ([drive])");
    for (const auto& [k, node] : *drive) {
      const std::string key(k.str());
      const model::ParameterSpec* spec = model::find_parameter(key);
      if (spec != nullptr && spec->section == "drive") {
        set_checked(p, *spec, number_from_node(node, source, "drive." + key), source,
                    "drive." + key);
      } else if (std::find(extra_drive_keys.begin(), extra_drive_keys.end(), key) ==
                 extra_drive_keys.end()) {
        throw ConfigError(source, "drive." + key, "unknown key (allowed: V0, f, C_dr, e_dr)");
      }
    }
  }
  read_motor_section(table, "model", source, p.motor);
}

void read_motor_section(const toml::table& table, const std::string& section,
                        const std::string& source, model::MotorParameters& motor) {
  const toml::node* node = table.get(section);
  if (node == nullptr) return;
  const toml::table* t = node->as_table();
  if (t == nullptr) throw ConfigError(source, section, "must be a table ([" + section + "])");
  model::Parameters p;
  p.motor = motor;
  for (const auto& [k, value] : *t) {
    const std::string key(k.str());
    const model::ParameterSpec* spec = model::find_parameter(key);
    if (spec == nullptr || spec->section != "model") {
      throw ConfigError(source, section + "." + key,
                        "unknown key (allowed: d_e, M, J, C, K, r, mu, F_N, sigma0, sigma1, "
                        "sigma2)");
    }
    set_checked(p, *spec, number_from_node(value, source, section + "." + key), source,
                section + "." + key);
  }
  motor = p.motor;
}

void apply_parameter_override(const std::string& assignment, model::Parameters& p) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos) {
    throw ConfigError("--set", assignment, "expected KEY=VALUE");
  }
  const std::string key = assignment.substr(0, eq);
  const model::ParameterSpec* spec = model::find_parameter(key);
  if (spec == nullptr) {
    std::string allowed;
    for (const auto& s : model::parameter_specs())
      allowed += (allowed.empty() ? "" : ", ") + std::string(s.name);
    throw ConfigError("--set", key, "unknown parameter (allowed: " + allowed + ")");
  }
  set_checked(p, *spec, parse_number(assignment.substr(eq + 1), "--set", key), "--set", key);
}

toml::table parse_config_file(const std::string& path) {
  try {
    return toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    const auto& where = e.source().begin;
    throw ConfigError(path, "line " + std::to_string(where.line), std::string(e.description()));
  }
}

model::Parameters load_model_config(const std::string& path) {
  const toml::table table = parse_config_file(path);
  for (const auto& [k, node] : table) {
    const std::string key(k.str());
    if (std::find(kKnownSections.begin(), kKnownSections.end(), key) == kKnownSections.end()) {
      std::string allowed;
      for (const auto& name : kKnownSections) allowed += (allowed.empty() ? "" : ", ") + name;
      throw ConfigError(path, key, "unknown section (allowed: " + allowed + ")");
    }
  }
  model::Parameters p;
  read_model_sections(table, path, p, kDriveLoopKeys);
  require_valid(p, path);
  return p;
}

void require_valid(const model::Parameters& p, const std::string& source) {
  const auto issues = model::validate(p);
  if (!issues.empty()) throw ConfigError(source, issues.front().name, issues.front().message);
}

}  // namespace piezo::config
