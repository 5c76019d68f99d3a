// What a run follows besides a waveform (a closed-loop move, the
// calibration experiment), and the board's zero and readings at rest.

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <vector>

#include "calibration.hpp"
#include "daemon_run.hpp"
#include "piezo/firmware/request_limits.hpp"
#include "piezo/firmware/rest_watch.hpp"
#include "piezo/firmware/wire_keys.hpp"
#include "piezo/protocol/message.hpp"

namespace piezo::daemon {
namespace {

using nlohmann::json;
using protocol::ProtocolError;
namespace code = protocol::code;

}  // namespace

json Daemon::move_to(const std::string& client, const json& args) {
  run_state_.require_can_start(client,
                               "move_to");  // before configure: a refused move changes nothing
  // One request per axis: the request itself, or one per target of a group
  // (`targets`: {axis: target_rad}), each with the group's other arguments.
  std::vector<std::pair<ServedAxis*, json>> requests;
  if (const auto t = args.find(wire_key::targets); t != args.end() && !t->is_null()) {
    if (args.contains(wire_key::target_rad) || args.contains(wire_key::axis)) {
      throw ProtocolError(code::bad_argument, wire_key::targets,
                          "move_to: targets: give targets (a group), or target_rad and axis, "
                          "not both");
    }
    if (!t->is_object() || t->empty()) {
      throw ProtocolError(code::bad_argument, wire_key::targets,
                          fmt::format("move_to: targets: a map of axis to target_rad, e.g. "
                                      "{{\"{}\": 0.01}} (axes: {})",
                                      axes_.front()->name(), axis_names()));
    }
    for (const auto& [name, target] : t->items()) {
      json one = args;
      one.erase(std::string(wire_key::targets));
      one[wire_key::target_rad] = target;
      one[wire_key::axis] = name;
      requests.emplace_back(&axis_of(one, "move_to"), std::move(one));
    }
    // In the board's order, whatever the map's.
    std::sort(requests.begin(), requests.end(),
              [](const auto& a, const auto& b) { return a.first->index < b.first->index; });
  } else {
    requests.emplace_back(&axis_of(args, "move_to"), args);
  }
  // Every move checked and planned before any starts: one refused, none moves.
  Program program;
  std::vector<protocol::StartReply::Move> taken;
  std::optional<double> lease_s;
  for (auto& [axis, one] : requests) {
    try {
      require_no_axis_fault(*axis, "move_to");
      const auto request = protocol::decode<protocol::MoveToRequest>(one);
      if (const auto breach = firmware::check_move(request.move, board_.daemon.duration_max_s)) {
        throw out_of_limits(breach->key, breach->message);
      }
      // A target the travel window excludes would only end in travel_limit.
      const auto& safety = axis->config.safety;
      if (request.move.target_rad < safety.travel_min_rad ||
          request.move.target_rad > safety.travel_max_rad) {
        throw out_of_limits(
            wire_key::target_rad,
            fmt::format("move_to: target_rad: {:g} rad is outside the axis's travel window "
                        "[{:g}, {:g}] rad (safety.travel_min_rad, safety.travel_max_rad)",
                        request.move.target_rad, safety.travel_min_rad, safety.travel_max_rad));
      }
      bool calibrated = false;
      const firmware::MoveSettings m = plan_move(*axis, request, calibrated);
      // Towards the target from where the axis stands (its readings at
      // rest): a move back inside from an end of the window is judged so.
      const std::optional<double> at = position_of(*axis).position_rad;
      const firmware::TravelHeading towards =
          at ? heading(*axis, request.move.target_rad >= *at ? 1 : -1, m.V0)
             : firmware::TravelHeading{};
      // Known now unless the readings at rest failed: then the move takes
      // its own, and the axis keeps it afterwards.
      const bool zero_before = axis->zero.known();
      // The request as taken: every field, and the coarse steps' waveform as used.
      protocol::MoveToRequest as_taken = request;
      const auto& d = configured_->drive;
      as_taken.V0 = d.V0;
      as_taken.f = d.f;
      as_taken.C_dr = d.C_dr;
      as_taken.e_dr = d.e_dr;
      as_taken.lease_s.reset();  // the reply's own
      taken.push_back({axis->name(), calibrated,
                       zero_before ? std::optional(m.zero_displacement_m) : std::nullopt,
                       as_taken});
      program.moves.push_back({axis, m, towards});
      lease_s = request.lease_s;
    } catch (const ProtocolError& e) {
      if (requests.size() == 1) throw;
      // A group's refusal names the axis whose move it refuses.
      throw ProtocolError(e.code(), std::string(wire_key::targets) + "." + axis->name(),
                          fmt::format("{}: {}", axis->name(), e.what()));
    }
  }
  protocol::StartReply started = start(client, lease_s, program, "move_to");
  for (std::size_t i = 0; i < taken.size(); ++i) {
    run_->parts[i]->move_takes_its_zero = !taken[i].zero_displacement_m;
  }
  started.moves = std::move(taken);
  return started;
}

firmware::MoveSettings Daemon::plan_move(ServedAxis& axis, const protocol::MoveToRequest& request,
                                         bool& calibrated) {
  const config::AxisConfig& c = axis.config;
  const std::optional<protocol::CalibrationRecord>& calibration = axis.calibration;
  firmware::AngleZero& zero = axis.zero;
  firmware::MoveSettings m;
  static_cast<firmware::MoveRequest&>(m) = request.move;
  // At rest before the move: the board's zero when it has none (the frame
  // of the target, and of the log's angles), and the sensor's noise when
  // no calibration gives it.
  const AtRest rest = !zero.known() || !calibration
                          ? read_at_rest(axis, 2 * ServedAxis::kRecentReadings)
                          : AtRest{};
  if (!zero.known() && rest.good >= 4) {
    zero.set(rest.mean_m);
    log_event(fmt::format("zero set at {:.9g} m (the mean of {} readings at rest before a move)",
                          rest.mean_m, rest.good));
  }
  const std::optional<double> noise = calibration      ? std::optional(calibration->noise_m)
                                      : rest.good >= 4 ? std::optional(rest.stddev_m)
                                                       : std::nullopt;
  // A tolerance finer than the sensor resolves would never be reached.
  if (noise) {
    const double smallest = smallest_tolerance_rad(*noise, c.sensor.r2_m);
    if (m.tolerance_rad < smallest) {
      throw out_of_limits(
          wire_key::tolerance_rad,
          fmt::format("{:g} rad is below what the sensor resolves: its noise is {:.3g} m "
                      "({:.3g} rad a reading, {} at rest); allowed: at least {:.3g} rad",
                      m.tolerance_rad, *noise, *noise / c.sensor.r2_m,
                      calibration ? wire_key::calibrated : "measured now", smallest));
    }
  }
  // The coarse steps' waveform: the caller's, or the calibration's fastest
  // frequency, or the board's [drive] values.
  model::DriveParameters d = c.model.drive;
  d.direction = model::Direction::forward;
  d.V0 = request.V0.value_or(d.V0);
  d.C_dr = request.C_dr.value_or(d.C_dr);
  d.e_dr = request.e_dr.value_or(d.e_dr);
  d.f = request.f.value_or(d.f);
  if (!request.f && calibration && calibration->fastest_f_hz &&
      std::abs(calibration->V0 - d.V0) <= 1e-9 * d.V0) {
    d.f = *calibration->fastest_f_hz;
  }
  (void)apply_configuration(axis, {d, request.move.timeout_s}, "move_to");
  m.zero_displacement_m = zero.displacement_m();
  m.r2_m = c.sensor.r2_m;
  m.V0 = d.V0;
  m.f = d.f;
  m.D = d.D();
  m.fine_V_max = firmware::kHoldFractionOfVmax * c.drive.limits.V_max;
  m.fast_slew_V_per_s = c.drive.limits.slew_V_per_s;
  // The model's (or a fitted config's) view of the motor; a calibration
  // replaces the step tables with measured ones. Uncalibrated, and with no
  // frequency asked for: the model's tables at 2f and 4f too.
  axis.planner.plan(m, false, board_.drive_rate_hz, c.drive.limits.slew_V_per_s);
  calibrated = calibration && apply_calibration(*calibration, request.f, m);
  if (!calibrated && !request.f) {
    axis.planner.plan(m, true, board_.drive_rate_hz, c.drive.limits.slew_V_per_s);
  }
  return m;
}

json Daemon::calibrate(const std::string& client, const json& args) {
  run_state_.require_can_start(client,
                               "calibrate");  // before configure: a refused one changes nothing
  ServedAxis& axis = axis_of(args, "calibrate");
  const config::AxisConfig& c = axis.config;
  const auto request = protocol::decode<protocol::CalibrateRequest>(args);
  const auto& lim = c.drive.limits;
  const auto& d0 = c.model.drive;
  if (request.V0 && !(*request.V0 > 0.0 && *request.V0 <= lim.V_max)) {
    throw out_of_limits(
        wire_key::V0,
        fmt::format("{:g} V (allowed: (0, {:g}] V, the board's V_max)", *request.V0, lim.V_max));
  }
  firmware::CalibrationPlan plan;
  plan.V0 = request.V0.value_or(std::min(d0.V0, lim.V_max));
  plan.D = d0.D();
  plan.r2_m = c.sensor.r2_m;
  plan.hold_V_max = firmware::kHoldFractionOfVmax * lim.V_max;
  plan.fast_slew_V_per_s = lim.slew_V_per_s;
  plan.flush_readings = std::max(10, static_cast<int>(std::ceil(0.1 * board_.sensor_rate_hz)));
  // The board's frequency, twice and four times it: as many as the board's
  // rate and slew limit allow at V0.
  const double f_max = std::min(firmware::max_drive_frequency(board_.drive_rate_hz),
                                lim.slew_V_per_s * std::min(plan.D, 1.0 - plan.D) / plan.V0);
  plan.frequencies = 0;
  for (const double factor : {1.0, 2.0, 4.0}) {
    if (factor * d0.f > f_max) break;
    plan.f_hz[static_cast<std::size_t>(plan.frequencies++)] = factor * d0.f;
  }
  if (plan.frequencies == 0) {
    throw out_of_limits(wire_key::V0,
                        fmt::format("at {:g} V the board's frequency {:g} Hz exceeds its "
                                    "slew limit; allowed: a lower V0",
                                    plan.V0, d0.f));
  }
  model::DriveParameters d = d0;
  d.direction = model::Direction::forward;
  d.V0 = plan.V0;
  d.f = plan.f_hz[static_cast<std::size_t>(plan.frequencies - 1)];
  (void)apply_configuration(axis, {d, 1.5 * plan.duration_s(board_.sensor_rate_hz) + 1.0},
                            "calibrate");
  protocol::StartReply started = start(client, request.lease_s, {{}, plan, {}}, "calibrate");
  started.calibration = protocol::StartReply::Calibration{
      static_cast<std::uint32_t>(plan.steps), plan.V0,
      std::vector<double>(plan.f_hz.begin(), plan.f_hz.begin() + plan.frequencies)};
  return started;
}

json Daemon::set_calibration(const std::string&, const json& args) {
  // The command table admitted the caller: a run under way is the controller's.
  if (running()) throw ProtocolError(code::bad_state, "", "set_calibration: a run is under way");
  ServedAxis& axis = axis_of(args, "set_calibration");
  if (!args.contains(wire_key::calibration)) {
    throw ProtocolError(code::bad_argument, wire_key::calibration,
                        "calibration: missing (a calibration map, or nil to clear it)");
  }
  const json& given = args.at(wire_key::calibration);
  if (given.is_null()) {
    axis.calibration.reset();
    if (!axis.calibration_file.empty()) {
      std::error_code ignored;
      std::filesystem::remove(axis.calibration_file, ignored);
    }
    log_event("calibration cleared");
    return protocol::SetCalibrationReply{};
  }
  const config::DriveSettings& drive = axis.config.drive;
  const std::optional<std::string> save_error = install_calibration(
      axis, checked_calibration(
                given, {drive.limits.V_max, firmware::max_drive_frequency(board_.drive_rate_hz)}));
  protocol::SetCalibrationReply reply{axis.calibration, std::nullopt, save_error};
  if (!axis.calibration_file.empty() && !save_error) reply.saved_to = axis.calibration_file;
  return reply;
}

std::optional<std::string> Daemon::install_calibration(ServedAxis& axis,
                                                       protocol::CalibrationRecord c) {
  axis.calibration = std::move(c);
  std::string kept = "in memory only (no piezod.calibration_file)";
  std::optional<std::string> save_error;
  if (!axis.calibration_file.empty()) {
    try {
      save_calibration(axis.calibration_file, *axis.calibration);
      kept = "kept in " + axis.calibration_file;
    } catch (const std::exception& e) {
      save_error = e.what();
      kept = fmt::format("NOT kept: {}", e.what());
    }
  }
  const auto& fastest = axis.calibration->fastest_f_hz;
  log_event(fmt::format("calibration installed on {}: fastest reliable {}, noise {:.3g} m; {}",
                        axis.name(),
                        fastest ? fmt::format("{:g} Hz", *fastest) : std::string("none"),
                        axis.calibration->noise_m, kept));
  return save_error;
}

json Daemon::set_zero(const std::string&, const json& args) {
  // The frame of a run's target (a move's) must not shift under it: the
  // zero is the controller's between runs, and nobody's during one.
  if (running())
    throw ProtocolError(code::bad_state, "", "zero: a run is under way; zero after it ends");
  ServedAxis& axis = axis_of(args, "zero");
  const auto last = axis.recent_displacement_m();
  if (!last) {
    throw ProtocolError(code::bad_state, "",
                        "zero: no sensor reading yet; the zero is the first reading of the "
                        "next run or move until then");
  }
  axis.zero.set(*last);
  log_event(fmt::format("zero of {} set at {:.9g} m", axis.name(), *last));
  return protocol::ZeroReply{position_of(axis)};
}

Daemon::AtRest Daemon::read_at_rest(ServedAxis& axis, std::size_t n) {
  const IdleReader::Hold sensors_held = idle_->hold();  // this thread reads them now
  hal::Clock& clock = *rig_.clock;
  clock.add_sleeper();  // the virtual clock schedules the threads it knows of
  const hal::TimeNs period = hal::from_seconds(1.0 / board_.sensor_rate_hz);
  hal::TimeNs next = clock.now();
  std::vector<double> readings;
  // The first readings after an idle gap may be the sensor's last ones
  // from before it (a simulated sensor's, measured 37 um off after a run of
  // steps): skipped.
  constexpr std::size_t kSkipped = 2;
  for (std::size_t i = 0; i < n + kSkipped; ++i, next += period) {
    clock.sleep_until(next);
    // A simulated plant advances only at a write: carried to now, the
    // reading sees the rotor at its time, not extrapolated from the stop.
    advance_simulated_rig();
    const hal::DisplacementReading r = axis.rig.sensor->read();
    if (i < kSkipped || r.status != hal::Status::ok || !std::isfinite(r.displacement_m)) continue;
    readings.push_back(r.displacement_m);
    axis.remember_reading(r.displacement_m);
  }
  clock.remove_sleeper();
  AtRest r;
  r.good = static_cast<int>(readings.size());
  if (readings.empty()) return r;
  double sum = 0.0;
  for (const double d : readings) sum += d;
  r.mean_m = sum / static_cast<double>(readings.size());
  if (readings.size() > 2)
    r.stddev_m = firmware::noise_of_readings(readings.data(), readings.size());
  return r;
}

}  // namespace piezo::daemon
