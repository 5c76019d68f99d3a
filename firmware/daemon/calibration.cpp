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

#include "piezo/config/read_file.hpp"
#include "piezo/firmware/wire_keys.hpp"
#include "piezo/protocol/error.hpp"

namespace piezo::daemon {
namespace {

using nlohmann::json;
using protocol::ProtocolError;
namespace code = protocol::code;

using protocol::CalibrationRecord;
constexpr std::size_t kFractions = firmware::MoveSettings::kStepFractions.size();
/// The settle's longest mean.
constexpr double kLongestMean = firmware::SettleMean::kMax;

ProtocolError bad(std::string_view key, const std::string& message) {
  const std::string path = fmt::format("{}.{}", wire_key::calibration, key);
  return {code::bad_argument, path, path + ": " + message};
}

std::string utc_now() {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&now, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

std::vector<double> step_fractions() {
  return {firmware::MoveSettings::kStepFractions.begin(),
          firmware::MoveSettings::kStepFractions.end()};
}

/// Derived figures: per frequency whether its steps are reliable and how
/// fast it moves; the fastest reliable one; the resolution.
void derive(CalibrationRecord& c) {
  // A step measured over `steps` periods between two means of
  // kRestReadings readings: its standard error, and a step is reliable
  // well above it.
  const double step_error = std::sqrt(2.0 / firmware::CalibrationProgram::kRestReadings) *
                            c.noise_m / (c.r2_m * c.steps_per_point);
  const double floor = std::max(10.0 * step_error, 1e-7);
  double best_speed = 0.0;
  c.fastest_f_hz.reset();
  for (auto& f : c.frequencies) {
    const double fwd = f.forward_rad.back();
    const double rev = -f.reverse_rad.back();
    f.reliable = fwd > floor && rev > floor;
    f.speed_rad_per_s = f.f_hz * std::min(fwd, rev);
    if (*f.reliable && *f.speed_rad_per_s > best_speed) {
      best_speed = *f.speed_rad_per_s;
      c.fastest_f_hz = f.f_hz;
    }
  }
  c.step_floor_rad = floor;
  c.noise_rad = c.noise_m / c.r2_m;
  c.resolution_rad = resolution_rad(c.noise_m, c.r2_m);
  c.smallest_tolerance_rad = smallest_tolerance_rad(c.noise_m, c.r2_m);
}

}  // namespace

double resolution_rad(double noise_m, double r2_m) {
  return 2.0 * noise_m / (r2_m * std::sqrt(kLongestMean));
}

double smallest_tolerance_rad(double noise_m, double r2_m) {
  return 2.0 * resolution_rad(noise_m, r2_m);
}

CalibrationRecord measured_calibration(const firmware::CalibrationPlan& plan,
                                       const firmware::CalibrationResult& result) {
  CalibrationRecord c;
  c.created = utc_now();
  c.V0 = plan.V0;
  c.D = plan.D;
  c.r2_m = plan.r2_m;
  c.steps_per_point = static_cast<std::uint32_t>(plan.steps);
  c.rest_readings = CalibrationRecord::RestReadings{
      static_cast<std::uint32_t>(plan.flush_readings),
      static_cast<std::uint32_t>(firmware::CalibrationProgram::kRestReadings)};
  c.step_fractions = step_fractions();
  c.noise_m = result.noise_m;
  c.rad_per_V = result.rad_per_V;
  for (int i = 0; i < plan.frequencies; ++i) {
    const auto k = static_cast<std::size_t>(i);
    c.frequencies.push_back({plan.f_hz[k],
                             {result.forward_rad[k].begin(), result.forward_rad[k].end()},
                             {result.reverse_rad[k].begin(), result.reverse_rad[k].end()},
                             std::nullopt,
                             std::nullopt});
  }
  derive(c);
  return c;
}

CalibrationRecord checked_calibration(CalibrationRecord c, const CalibrationLimits& limits) {
  if (const auto breach = protocol::check_calibration_ranges(c, limits.V_max, limits.f_max_hz)) {
    throw bad(breach->key, breach->message);
  }
  if (c.created.empty()) c.created = utc_now();
  if (!c.step_fractions.empty() && c.step_fractions != step_fractions()) {
    throw bad(wire_key::step_fractions, fmt::format("allowed: {}", json(step_fractions()).dump()));
  }
  c.step_fractions = step_fractions();
  if (c.frequencies.empty() || c.frequencies.size() > firmware::CalibrationPlan::kMaxFrequencies) {
    throw bad(wire_key::frequencies,
              fmt::format("1 to {} entries {{f_hz, forward_rad, reverse_rad}}",
                          firmware::CalibrationPlan::kMaxFrequencies));
  }
  for (std::size_t i = 0; i < c.frequencies.size(); ++i) {
    const auto& f = c.frequencies[i];
    if (f.forward_rad.size() != kFractions || f.reverse_rad.size() != kFractions) {
      throw bad(fmt::format("frequencies[{}]", i),
                fmt::format("forward_rad and reverse_rad must be {} numbers each (one per "
                            "step_fractions)",
                            kFractions));
    }
  }
  // A host's fitted model: kept as given (a map of parameter values and
  // their intervals), for the observer of later runs.
  if (!c.model.is_object()) c.model = nullptr;
  derive(c);
  return c;
}

CalibrationRecord checked_calibration(const json& given, const CalibrationLimits& limits) {
  if (!given.is_object()) throw bad("", "must be a map (docs/protocol.md, \"Calibration\")");
  try {
    return checked_calibration(protocol::decode<CalibrationRecord>(given), limits);
  } catch (const ProtocolError& e) {
    if (e.key().rfind(wire_key::calibration, 0) == 0) throw;
    throw ProtocolError(code::bad_argument, "calibration." + e.key(),
                        std::string("calibration.") + e.what());
  }
}

bool apply_calibration(const CalibrationRecord& c, std::optional<double> f,
                       firmware::MoveSettings& m) {
  if (std::abs(c.V0 - m.V0) > 1e-9 * m.V0) return false;
  const auto table = [](const CalibrationRecord::Frequency& entry,
                        firmware::MoveSettings::Alternative& a) {
    a.f = entry.f_hz;
    for (std::size_t i = 0; i < kFractions; ++i) {
      // Magnitudes; a step the wrong way or none counts as (almost) none:
      // the measured steps correct it, the stall check ends it.
      a.forward_rad[i] = std::max(1e-9, entry.forward_rad[i]);
      a.reverse_rad[i] = std::max(1e-9, -entry.reverse_rad[i]);
    }
  };
  const double want = f ? *f : c.fastest_f_hz.value_or(std::numeric_limits<double>::quiet_NaN());
  std::vector<firmware::MoveSettings::Alternative> others;
  bool found = false;
  for (const auto& entry : c.frequencies) {
    firmware::MoveSettings::Alternative a;
    table(entry, a);
    if (std::abs(a.f - want) <= 1e-9 * a.f) {
      m.f = a.f;
      m.step_forward_rad = a.forward_rad;
      m.step_reverse_rad = a.reverse_rad;
      found = true;
    } else if (!f && entry.reliable.value_or(false)) {
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
  m.rad_per_V = c.rad_per_V;
  m.noise_prior_m = c.noise_m;
  return true;
}

/// The axis's steady velocity against its drive, one way (+1 forward).
firmware::VelocityBranch velocity_branch(const protocol::CalibrationRecord& c, int direction) {
  firmware::VelocityBranch b;
  for (const auto& f : c.frequencies) {
    firmware::VelocityBranch::Table steps{};
    const auto& way = direction > 0 ? f.forward_rad : f.reverse_rad;
    for (std::size_t i = 0; i < steps.size() && i < way.size(); ++i) {
      steps[i] = std::max(0.0, direction * way[i]);
    }
    b.add(f.f_hz, steps, f.reliable.value_or(false));
  }
  return b;
}

VelocityRange velocity_range(const protocol::CalibrationRecord& c) {
  const firmware::VelocityBranch forward = velocity_branch(c, 1), reverse = velocity_branch(c, -1);
  if (forward.empty() || reverse.empty()) return {};
  // What holds both ways.
  return {std::max(forward.base_rate(), reverse.base_rate()),
          std::min(forward.top(), reverse.top())};
}

std::optional<CalibrationRecord> load_calibration(const std::string& path,
                                                  const CalibrationLimits& limits) {
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

void save_calibration(const std::string& path, const CalibrationRecord& c) {
  const std::string tmp = path + ".new";
  const std::string text = json(c).dump(2) + "\n";
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
