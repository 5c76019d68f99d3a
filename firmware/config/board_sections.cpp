// The board's sections: its devices ([drive], [sensor], [lines], each with
// its chosen backend's own section), [safety] and [piezod] (sections.hpp).

#include <fmt/format.h>

#include <map>
#include <string>
#include <vector>

#include "model_config.hpp"
#include "piezo/config/config_error.hpp"
#include "sections.hpp"

namespace piezo::config::sections {
namespace {

/// A kind's `backend` key, and the keys that moved from its section into
/// the backends' refused naming their new place.
template <class Base>
void choose_backend(SectionReader& r, Backends<Base>& kind) {
  std::vector<std::string> names;
  std::map<std::string, std::vector<std::string>> moved;
  for (const auto& b : kind.all) {
    names.emplace_back(b->name());
    for (const hal::MovedKey& m : b->moved_keys())
      moved[std::string(m.old_key)].emplace_back(m.new_key);
  }
  r.choice("backend", kind.backend, names);
  for (const auto& [old_key, now] : moved) r.moved(old_key, now);
}

/// Every backend's own section ([KIND.SECTION]), read by the backend.
template <class Base>
void read_backend_sections(SectionReader& r, Backends<Base>& kind, Backends_read which) {
  for (const auto& b : kind.all) {
    if (which == Backends_read::chosen && b.get() != &kind.chosen()) continue;
    SectionReader own = r.subsection(std::string(b->section()));
    b->read(own);
    own.finish();
  }
}

/// A loop rate: the board's ([drive], [sensor]), or refused in an axis's
/// own sections (`rate_hz` null), naming where it is set.
void read_board_rate(SectionReader& r, double* rate_hz, const Range& allowed,
                     const std::string& section) {
  if (rate_hz != nullptr) {
    r.number("rate_hz", *rate_hz, allowed, "Hz");
  } else if (r.has("rate_hz")) {
    throw ConfigError(r.source(), r.name("rate_hz"),
                      fmt::format("the board's loop rate, the same for every axis (one tick "
                                  "drives and reads them all); allowed: {}.rate_hz alone",
                                  section));
  }
}

}  // namespace

void read_drive(SectionReader r, DriveSettings& d, model::Parameters& waveform, Backends_read which,
                double* rate_hz) {
  choose_backend(r, d.backends);
  read_waveform(r, waveform);
  read_board_rate(r, rate_hz, {100.0, 100'000.0}, "drive");
  r.number("V_min", d.limits.V_min, {0.0, 1000.0}, "V");
  r.number("V_max", d.limits.V_max, {0.0, 1000.0, true}, "V");
  r.number("slew_V_per_s", d.limits.slew_V_per_s, kPositive, "V/s");
  r.number("amplifier_gain", d.amplifier_gain, {0.0, 1000.0, true});
  read_backend_sections(r, d.backends, which);
  r.finish();
}

void read_sensor(SectionReader r, SensorSettings& s, Backends_read which, double* rate_hz) {
  choose_backend(r, s.backends);
  read_board_rate(r, rate_hz, {1.0, 100'000.0}, "sensor");
  r.number("r2_m", s.r2_m, {0.0, 10.0, true}, "m");
  r.number("range_min_m", s.range_min_m, {-1e3, 1e3}, "m");
  r.number("range_max_m", s.range_max_m, {-1e3, 1e3}, "m");
  read_backend_sections(r, s.backends, which);
  r.finish();
}

void read_lines(SectionReader r, LinesSettings& l, Backends_read which) {
  choose_backend(r, l.backends);
  read_backend_sections(r, l.backends, which);
  r.finish();
}

void read_daemon(SectionReader r, DaemonSettings& d) {
  r.text("listen", d.listen);
  r.number("lease_s", d.lease_s, {0.05, 60.0}, "s");
  r.number("lease_max_s", d.lease_max_s, {0.05, 600.0}, "s");
  r.number("recorder_s", d.recorder_s, {1.0, 3600.0}, "s");
  r.text("spill_file", d.spill_file);
  r.text("calibration_file", d.calibration_file);
  r.number("duration_max_s", d.duration_max_s, {0.0, 1e7, true}, "s");
  r.number("fetch_samples_per_s", d.fetch_samples_per_s, {1e3, 1e9}, "samples/s");
  r.number("idle_rate_hz", d.idle_rate_hz, {0.0, 1000.0}, "Hz");
  r.text("secret_key_file", d.secret_key_file);
  r.text("authorized_keys_file", d.authorized_keys_file);
  r.flag("insecure", d.insecure);
  r.finish();
}

void read_safety(SectionReader& r, firmware::SafetySettings& s) {
  r.number("sensor_stale_s", s.sensor_stale_s, {0.0, 60.0, true}, "s");
  int sensor_errors = static_cast<int>(s.max_sensor_errors);
  int drive_errors = static_cast<int>(s.max_drive_errors);
  r.integer("max_sensor_errors", sensor_errors, 1, 1'000'000);
  r.integer("max_drive_errors", drive_errors, 1, 1'000'000);
  s.max_sensor_errors = static_cast<std::uint32_t>(sensor_errors);
  s.max_drive_errors = static_cast<std::uint32_t>(drive_errors);
  r.number("ramp_down_V_per_s", s.ramp_down_V_per_s, kPositive, "V/s");
  r.number("stop_confirm_s", s.stop_confirm_s, {0.01, 30.0}, "s");
  r.number("travel_min_rad", s.travel_min_rad, {-10.0, 10.0}, "rad");
  r.flag("protect_runs", s.protect_runs);
  r.integer("stall_periods", s.stall_periods, 1, 16);
  r.number("travel_max_rad", s.travel_max_rad, {-10.0, 10.0}, "rad");
}

}  // namespace piezo::config::sections
