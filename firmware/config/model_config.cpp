#include "model_config.hpp"

#include <toml++/toml.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string_view>

#include "piezo/config/config_error.hpp"
#include "piezo/config/read_file.hpp"

namespace piezo::config {
namespace {

/// Reads every parameter of `section` ("drive" or "model") into `p`.
void read_specs(SectionReader& r, std::string_view section, model::Parameters& p) {
  for (const auto& spec : model::parameter_specs()) {
    if (spec.section != section) continue;
    const Range allowed{spec.min, spec.max, !spec.min_inclusive, !spec.max_inclusive};
    r.number(std::string(spec.name), spec.ref(p), allowed, std::string(spec.unit));
  }
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

void read_waveform(SectionReader& drive, model::Parameters& p) {
  read_specs(drive, "drive", p);
  drive.choice("direction", p.drive.direction, model::kDirectionNames);
}

void read_motor(SectionReader& section, model::MotorParameters& motor) {
  model::Parameters p;
  p.motor = motor;
  read_specs(section, "model", p);
  motor = p.motor;
}

void set_parameter(model::Parameters& p, const std::string& name, double value,
                   const std::string& source) {
  const model::ParameterSpec* spec = model::find_parameter(name);
  if (spec == nullptr) {
    std::string allowed;
    for (const auto& s : model::parameter_specs())
      allowed += (allowed.empty() ? "" : ", ") + std::string(s.name);
    throw ConfigError(source, name, "unknown parameter (allowed: " + allowed + ")");
  }
  if (!spec->admits(value)) {
    throw ConfigError(source, name,
                      "value " + std::to_string(value) + " " + std::string(spec->unit) +
                          " is outside the allowed range " + spec->range_text());
  }
  spec->ref(p) = value;
}

void apply_parameter_override(const std::string& assignment, model::Parameters& p) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos) {
    throw ConfigError("--set", assignment, "expected KEY=VALUE");
  }
  const std::string key = assignment.substr(0, eq);
  // An unknown name is refused (naming the known ones) before its value is read.
  if (model::find_parameter(key) == nullptr) set_parameter(p, key, 0.0, "--set");
  set_parameter(p, key, parse_number(assignment.substr(eq + 1), "--set", key), "--set");
}

void require_ascii_outside_comments(std::string_view text, const std::string& source) {
  bool comment = false, quoted = false;
  char quote = 0;
  int line = 1;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n') {
      ++line;
      comment = false;
      continue;
    }
    if (comment) continue;
    if (static_cast<unsigned char>(c) >= 0x80) {
      throw ConfigError(source, "line " + std::to_string(line),
                        "non-ASCII character outside a comment (allowed: ASCII; accents and "
                        "symbols such as µ only after #)");
    }
    if (quoted) {
      if (c == '\\' && quote == '"') {
        ++i;  // an escaped character, the quote among them
      } else if (c == quote) {
        quoted = false;
      }
    } else if (c == '"' || c == '\'') {
      quoted = true;
      quote = c;
    } else if (c == '#') {
      comment = true;
    }
  }
}

std::string read_config_file(const std::string& path) {
  auto text = read_file(path);
  if (!text) throw ConfigError(path, "file", "cannot be read");
  return std::move(*text);
}

toml::table parse_config_file(const std::string& path) {
  return parse_config_text(read_config_file(path), path);
}

toml::table parse_config_text(const std::string& text, const std::string& path) {
  // toml++ 3.3 (Debian 12) reaches "unreachable" code on some non-ASCII
  // characters (upstream issue #295, found here by fuzzing): text outside
  // comments is checked first, so that a config never gets that far.
  require_ascii_outside_comments(text, path);
  try {
    return toml::parse(text, path);
  } catch (const toml::parse_error& e) {
    const auto& where = e.source().begin;
    throw ConfigError(path, "line " + std::to_string(where.line), std::string(e.description()));
  }
}

void require_valid(const model::Parameters& p, const std::string& source) {
  const auto issues = model::validate(p);
  if (!issues.empty()) throw ConfigError(source, issues.front().name, issues.front().message);
}

}  // namespace piezo::config
