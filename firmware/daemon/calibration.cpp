#include "calibration.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "piezo/protocol/error.hpp"
#include "piezo/read_file.hpp"

namespace piezo::daemon {
namespace {

using nlohmann::json;
using protocol::ProtocolError;
namespace code = protocol::code;

constexpr int kVersion = 1;
constexpr std::size_t kFractions = firmware::MoveSettings::kStepFractions.size();
/// The settle's longest mean.
constexpr double kLongestMean = firmware::SettleMean::kMax;

ProtocolError bad(const std::string& key, const std::string& message) {
  return {code::bad_argument, "calibration." + key, "calibration." + key + ": " + message};
}

double number(const json& c, const std::string& key, double lo, double hi, const char* unit) {
  if (!c.contains(key) || !c.at(key).is_number()) throw bad(key, "missing or not a number");
  const double v = c.at(key).get<double>();
  if (!(v >= lo && v <= hi)) {
    throw bad(key, fmt::format("{:g} {}; allowed: [{:g}, {:g}] {}", v, unit, lo, hi, unit));
  }
  return v;
}

std::vector<double> row(const json& f, const std::string& key, const std::string& where) {
  if (!f.contains(key) || !f.at(key).is_array() || f.at(key).size() != kFractions) {
    throw bad(where + "." + key,
              fmt::format("must be {} numbers (one per step_fractions)", kFractions));
  }
  std::vector<double> r;
  for (const auto& v : f.at(key)) {
    if (!v.is_number() || !std::isfinite(v.get<double>()) || std::abs(v.get<double>()) > 1.0) {
      throw bad(where + "." + key, "each a step per period in rad, within [-1, 1]");
    }
    r.push_back(v.get<double>());
  }
  return r;
}

std::string utc_now() {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&now, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

/// Derived figures: per frequency whether its steps are reliable and how
/// fast it moves; the fastest reliable one; the resolution.
void derive(json& c) {
  const double noise = c.at("noise_m").get<double>(), r2 = c.at("r2_m").get<double>();
  const int steps = c.at("steps_per_point").get<int>();
  // A step measured over `steps` periods between two means of
  // kRestReadings readings: its standard error, and a step is reliable
  // well above it.
  const double step_error =
      std::sqrt(2.0 / firmware::CalibrationProgram::kRestReadings) * noise / (r2 * steps);
  const double floor = std::max(10.0 * step_error, 1e-7);
  double best_speed = 0.0;
  json fastest = nullptr;
  for (auto& f : c.at("frequencies")) {
    const double fwd = f.at("forward_rad").back().get<double>();
    const double rev = -f.at("reverse_rad").back().get<double>();
    const bool reliable = fwd > floor && rev > floor;
    const double speed = f.at("f_hz").get<double>() * std::min(fwd, rev);
    f["reliable"] = reliable;
    f["speed_rad_per_s"] = speed;
    if (reliable && speed > best_speed) {
      best_speed = speed;
      fastest = f.at("f_hz");
    }
  }
  c["step_floor_rad"] = floor;
  c["fastest_f_hz"] = fastest;
  c["noise_rad"] = noise / r2;
  c["resolution_rad"] = resolution_rad(noise, r2);
  c["smallest_tolerance_rad"] = smallest_tolerance_rad(noise, r2);
}

}  // namespace

double resolution_rad(double noise_m, double r2_m) {
  return 2.0 * noise_m / (r2_m * std::sqrt(kLongestMean));
}

double smallest_tolerance_rad(double noise_m, double r2_m) {
  return 2.0 * resolution_rad(noise_m, r2_m);
}

json calibration_json(const firmware::CalibrationPlan& plan,
                      const firmware::CalibrationResult& result) {
  json c{{"version", kVersion},
         {"created", utc_now()},
         {"V0", plan.V0},
         {"D", plan.D},
         {"r2_m", plan.r2_m},
         {"steps_per_point", plan.steps},
         {"rest_readings",
          {{"skipped", plan.flush_readings},
           {"averaged", firmware::CalibrationProgram::kRestReadings}}},
         {"step_fractions", firmware::MoveSettings::kStepFractions},
         {"noise_m", result.noise_m},
         {"rad_per_V", result.rad_per_V},
         {"model", nullptr}};
  json frequencies = json::array();
  for (int i = 0; i < plan.frequencies; ++i) {
    const auto k = static_cast<std::size_t>(i);
    frequencies.push_back({{"f_hz", plan.f_hz[k]},
                           {"forward_rad", result.forward_rad[k]},
                           {"reverse_rad", result.reverse_rad[k]}});
  }
  c["frequencies"] = frequencies;
  derive(c);
  return c;
}

json checked_calibration(const json& given, const CalibrationLimits& limits) {
  if (!given.is_object()) throw bad("", "must be a map (docs/protocol.md, \"Calibration\")");
  if (!given.contains("version") || given.at("version") != kVersion) {
    throw bad("version", fmt::format("allowed: {}", kVersion));
  }
  json c{{"version", kVersion}};
  c["created"] = given.contains("created") && given.at("created").is_string()
                     ? given.at("created").get<std::string>()
                     : utc_now();
  c["V0"] = number(given, "V0", 0.0, limits.V_max, "V");
  c["D"] = number(given, "D", 0.01, 0.99, "");
  c["r2_m"] = number(given, "r2_m", 1e-6, 10.0, "m");
  c["steps_per_point"] = static_cast<int>(number(given, "steps_per_point", 1, 1000, "periods"));
  if (given.contains("rest_readings")) c["rest_readings"] = given.at("rest_readings");
  c["step_fractions"] = firmware::MoveSettings::kStepFractions;
  if (given.contains("step_fractions") && given.at("step_fractions") != c["step_fractions"]) {
    throw bad("step_fractions", fmt::format("allowed: {}", c["step_fractions"].dump()));
  }
  c["noise_m"] = number(given, "noise_m", 0.0, 1e-2, "m");
  c["rad_per_V"] = number(given, "rad_per_V", 1e-9, 1e-2, "rad/V");
  if (!given.contains("frequencies") || !given.at("frequencies").is_array() ||
      given.at("frequencies").empty() ||
      given.at("frequencies").size() > firmware::CalibrationPlan::kMaxFrequencies) {
    throw bad("frequencies", fmt::format("1 to {} entries {{f_hz, forward_rad, reverse_rad}}",
                                         firmware::CalibrationPlan::kMaxFrequencies));
  }
  json frequencies = json::array();
  for (std::size_t i = 0; i < given.at("frequencies").size(); ++i) {
    const json& f = given.at("frequencies")[i];
    const std::string where = fmt::format("frequencies[{}]", i);
    if (!f.is_object()) throw bad(where, "must be a map {f_hz, forward_rad, reverse_rad}");
    frequencies.push_back({{"f_hz", number(f, "f_hz", 1e-3, limits.f_max_hz, "Hz")},
                           {"forward_rad", row(f, "forward_rad", where)},
                           {"reverse_rad", row(f, "reverse_rad", where)}});
  }
  c["frequencies"] = frequencies;
  // A host's fitted model: kept as given (a map of parameter values and
  // their intervals), for the observer of later runs.
  c["model"] =
      given.contains("model") && given.at("model").is_object() ? given.at("model") : json(nullptr);
  derive(c);
  return c;
}

bool apply_calibration(const json& c, std::optional<double> f, firmware::MoveSettings& m) {
  if (std::abs(c.at("V0").get<double>() - m.V0) > 1e-9 * m.V0) return false;
  const auto table = [](const json& entry, firmware::MoveSettings::Alternative& a) {
    a.f = entry.at("f_hz").get<double>();
    for (std::size_t i = 0; i < kFractions; ++i) {
      // Magnitudes; a step the wrong way or none counts as (almost) none:
      // the measured steps correct it, the stall check ends it.
      a.forward_rad[i] = std::max(1e-9, entry.at("forward_rad")[i].get<double>());
      a.reverse_rad[i] = std::max(1e-9, -entry.at("reverse_rad")[i].get<double>());
    }
  };
  const double want = f                                  ? *f
                      : c.at("fastest_f_hz").is_number() ? c.at("fastest_f_hz").get<double>()
                                                         : std::numeric_limits<double>::quiet_NaN();
  std::vector<firmware::MoveSettings::Alternative> others;
  bool found = false;
  for (const auto& entry : c.at("frequencies")) {
    firmware::MoveSettings::Alternative a;
    table(entry, a);
    if (std::abs(a.f - want) <= 1e-9 * a.f) {
      m.f = a.f;
      m.step_forward_rad = a.forward_rad;
      m.step_reverse_rad = a.reverse_rad;
      found = true;
    } else if (!f && entry.at("reliable").get<bool>()) {
      others.push_back(a);  // tried when the chosen one steps far less than measured
    }
  }
  if (!found) return false;
  std::sort(others.begin(), others.end(), [](const auto& a, const auto& b) {
    return a.f * std::min(a.forward_rad.back(), a.reverse_rad.back()) >
           b.f * std::min(b.forward_rad.back(), b.reverse_rad.back());
  });
  m.alternative_count = 0;
  for (const auto& a : others) {
    if (m.alternative_count == firmware::MoveSettings::kMaxAlternatives) break;
    m.alternatives[static_cast<std::size_t>(m.alternative_count++)] = a;
  }
  m.rad_per_V = c.at("rad_per_V").get<double>();
  m.noise_prior_m = c.at("noise_m").get<double>();
  return true;
}

std::optional<json> load_calibration(const std::string& path, const CalibrationLimits& limits) {
  const auto text = read_file(path);
  if (!text) {
    if (!std::filesystem::exists(path)) return std::nullopt;
    throw std::runtime_error("piezod.calibration_file: cannot read " + path);
  }
  try {
    return checked_calibration(json::parse(*text), limits);
  } catch (const std::exception& e) {
    throw std::runtime_error(fmt::format("piezod.calibration_file: {}: {}", path, e.what()));
  }
}

void save_calibration(const std::string& path, const json& c) {
  const std::string tmp = path + ".new";
  const std::string text = c.dump(2) + "\n";
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw std::runtime_error("piezod.calibration_file: cannot write " + tmp);
  const bool written = ::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size()) &&
                       ::fsync(fd) == 0;
  ::close(fd);
  if (!written || std::rename(tmp.c_str(), path.c_str()) != 0) {
    throw std::runtime_error("piezod.calibration_file: cannot write " + path);
  }
}

}  // namespace piezo::daemon
