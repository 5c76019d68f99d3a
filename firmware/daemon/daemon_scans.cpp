// A scan's life on the board: its plan from the request and the axis's
// calibration (velocity branch, run-up, triggers), the pulses it fires
// (streamed and kept), and its account.

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <zmq_addon.hpp>

#include "calibration.hpp"
#include "daemon_run.hpp"
#include "piezo/firmware/wire_keys.hpp"
#include "piezo/model/simulate.hpp"
#include "piezo/model/waveform.hpp"
#include "piezo/protocol/dictionary.hpp"
#include "piezo/protocol/message.hpp"
#include "piezo/protocol/topics.hpp"

namespace piezo::daemon {
namespace {

using nlohmann::json;
using protocol::ProtocolError;
namespace code = protocol::code;
namespace args = firmware::arguments;

/// The command, in requests' refusals.
constexpr const char* kScan = protocol::ScanRequest::kCommand.data();

constexpr double kDefaultAcceleration_s = 0.2;
constexpr double kDefaultWidth_s = 1e-3;
/// PI's rule for a position trigger: its step at least 5 times the
/// sensor's peak-to-peak noise, taken as 6 standard deviations of a reading.
constexpr double kStepOverPeakToPeak = 5.0, kPeakToPeakOverSigma = 6.0;
/// A scan's approach to its run-up: a move, its tolerance a tenth of the
/// run-up, and at least this many times the smallest the sensor allows.
constexpr double kApproachShareOfRunUp = 0.1;
constexpr double kApproachToleranceFactor = 4.0;
/// The run-up's margin beyond what the acceleration covers: drive periods
/// at the scan's velocity for the loop to lock on.
constexpr double kLockPeriods = 10.0;

const char* to_string(firmware::ScanStage p) {
  switch (p) {
    case firmware::ScanStage::approach:
      return "approach";
    case firmware::ScanStage::run_up:
      return "run_up";
    case firmware::ScanStage::span:
      return "span";
    case firmware::ScanStage::run_down:
      return "run_down";
    case firmware::ScanStage::done:
      return "done";
    case firmware::ScanStage::failed:
      break;
  }
  return "failed";
}

}  // namespace

std::vector<protocol::ArgumentSpec> Daemon::scan_specs() const {
  std::vector<protocol::ArgumentSpec> out = protocol::specs_of<protocol::ScanRequest>();
  for (protocol::ArgumentSpec& a : out) {
    if (!a.required) continue;
    a.required = false;
    a.default_text = "required, unless `scans` names each axis's";
  }
  protocol::ArgumentSpec axis = axis_spec();
  if (axis.required) {
    axis.required = false;
    axis.default_text = "required, unless `scans` names the axes";
  }
  out.push_back(std::move(axis));
  protocol::ArgumentSpec scans;
  scans.name = wire_key::scans;
  scans.type = firmware::ArgumentType::map;
  scans.default_text = "none: one axis's scan (`axis`)";
  scans.doc =
      "a group scan: {axis: {from_rad, to_rad, velocity_rad_per_s, ...}, ...}, each axis with "
      "its own arguments (the request's own hold for what an axis leaves out), all started "
      "on one tick";
  out.push_back(std::move(scans));
  return out;
}

json Daemon::scan(const std::string& client, const json& request_args) {
  run_state_.require_can_start(client, kScan);
  std::vector<std::pair<ServedAxis*, json>> requests;
  if (const auto s = request_args.find(wire_key::scans); s != request_args.end() && !s->is_null()) {
    if (request_args.contains(wire_key::axis)) {
      throw ProtocolError(code::bad_argument, wire_key::scans,
                          "scan: scans: give scans (a group), or one axis's arguments, not both");
    }
    if (!s->is_object() || s->empty()) {
      throw ProtocolError(
          code::bad_argument, wire_key::scans,
          fmt::format("scan: scans: a map of axis to its scan, e.g. {{\"{}\": {{\"from_rad\": 0, "
                      "\"to_rad\": 0.05, \"velocity_rad_per_s\": 0.01}}}} (axes: {})",
                      axes_.front()->name(), axis_names()));
    }
    for (const auto& [name, own] : s->items()) {
      if (!own.is_object()) {
        throw ProtocolError(code::bad_argument, fmt::format("{}.{}", wire_key::scans, name),
                            fmt::format("scan: scans.{}: a map of that axis's arguments", name));
      }
      json one = request_args;
      one.erase(std::string(wire_key::scans));
      for (const auto& [key, value] : own.items()) one[key] = value;
      one[wire_key::axis] = name;
      requests.emplace_back(&axis_of(one, kScan), std::move(one));
    }
    std::sort(requests.begin(), requests.end(),
              [](const auto& a, const auto& b) { return a.first->index < b.first->index; });
  } else {
    requests.emplace_back(&axis_of(request_args, kScan), request_args);
  }
  // Every axis's scan planned before any starts: one refused, none moves.
  Program program;
  std::vector<protocol::ScanAccount> taken;
  std::optional<double> lease_s;
  double duration_s = 0.0;
  for (auto& [axis, one] : requests) {
    try {
      require_no_axis_fault(*axis, kScan);
      const auto request = protocol::decode<protocol::ScanRequest>(one);
      protocol::ScanAccount account;
      double scan_s = 0.0;
      firmware::ScanSettings s = plan_scan(*axis, request, account, scan_s);
      duration_s = std::max(duration_s, scan_s);
      const std::optional<double> at = position_of(*axis).position_rad;
      const double target = s.approach.target_rad;
      const firmware::TravelHeading towards =
          at ? heading(*axis, target >= *at ? 1 : -1, s.V0) : firmware::TravelHeading{};
      program.scans.push_back({axis, s, towards});
      taken.push_back(std::move(account));
      lease_s = request.lease_s;
    } catch (const ProtocolError& e) {
      if (requests.size() == 1) throw;
      throw ProtocolError(e.code(), std::string(wire_key::scans) + "." + axis->name(),
                          fmt::format("{}: {}", axis->name(), e.what()));
    }
  }
  if (duration_s > board_.daemon.duration_max_s) {
    throw out_of_limits(
        wire_key::velocity_rad_per_s,
        fmt::format("scan: the scan would take {:.1f} s with its approach, beyond the board's "
                    "longest run ({:g} s, duration_max_s); allowed: a faster velocity or a "
                    "shorter span",
                    duration_s, board_.daemon.duration_max_s));
  }
  model::DriveParameters d = requests.front().first->config.model.drive;
  d.V0 = program.scans.front().settings.V0;
  (void)apply_configuration(*requests.front().first, {d, duration_s}, kScan);
  protocol::StartReply started = start(client, lease_s, program, kScan);
  for (std::size_t i = 0; i < taken.size(); ++i) run_->parts[i]->scan_taken = taken[i];
  started.scans = std::move(taken);
  return started;
}

firmware::ScanSettings Daemon::plan_scan(ServedAxis& axis, const protocol::ScanRequest& r,
                                         protocol::ScanAccount& account, double& duration_s) {
  const config::AxisConfig& c = axis.config;
  const auto& safety = c.safety;
  if (!axis.calibration) {
    throw ProtocolError(code::bad_state, wire_key::velocity_rad_per_s,
                        fmt::format("scan: axis {} is not calibrated: its velocity against its "
                                    "drive is unknown; run calibrate on it first",
                                    axis.name()));
  }
  const protocol::CalibrationRecord& cal = *axis.calibration;
  for (const auto& [a, value] :
       {std::pair{args::from_rad, r.from_rad}, std::pair{args::to_rad, r.to_rad}}) {
    if (!a.allowed.admits(value)) {
      throw out_of_limits(a.name,
                          fmt::format("{:g} rad; allowed: {} rad", value, a.allowed.text()));
    }
  }
  if (r.to_rad == r.from_rad) {
    throw ProtocolError(code::bad_argument, wire_key::to_rad,
                        "scan: to_rad: equal to from_rad; a scan spans an angle");
  }
  const int dir = r.to_rad > r.from_rad ? 1 : -1;
  const VelocityRange range = velocity_range(cal);
  if (range.top <= 0.0 || !(r.velocity_rad_per_s >= range.base_rate) ||
      !(r.velocity_rad_per_s <= range.top)) {
    throw out_of_limits(
        wire_key::velocity_rad_per_s,
        range.top <= 0.0
            ? fmt::format("axis {}'s calibration has no reliable steady velocity both ways; "
                          "calibrate it again",
                          axis.name())
            : fmt::format("{:g} rad/s; allowed: [{:.4g}, {:.4g}] rad/s (axis {}'s base rate and "
                          "highest steady velocity, from its calibration)",
                          r.velocity_rad_per_s, range.base_rate, range.top, axis.name()));
  }
  const auto checked_time = [](const firmware::Argument& a, std::optional<double> v,
                               double fallback) {
    const double value = v.value_or(fallback);
    if (!a.allowed.admits(value)) {
      throw out_of_limits(a.name, fmt::format("{:g} s; allowed: {} s", value, a.allowed.text()));
    }
    return value;
  };
  firmware::ScanSettings s;
  s.from_rad = r.from_rad;
  s.to_rad = r.to_rad;
  s.velocity_rad_per_s = r.velocity_rad_per_s;
  s.acceleration_s = checked_time(args::acceleration_s, r.acceleration_s, kDefaultAcceleration_s);
  s.deceleration_s = checked_time(args::deceleration_s, r.deceleration_s, s.acceleration_s);
  s.r2_m = c.sensor.r2_m;
  s.V0 = cal.V0;
  s.D = cal.D;
  s.sensor_rate_hz = board_.sensor_rate_hz;
  s.branch = velocity_branch(cal, dir);
  // The run-up: what the acceleration covers from the base rate, a few
  // periods to lock on, and the filtered angle's lag; the run-down alike.
  const double v = r.velocity_rad_per_s;
  const double period_s = 1.0 / s.branch.drive_for(v).f_hz;
  const double filter_s = static_cast<double>(firmware::ReadingWindow::kSize) / s.sensor_rate_hz;
  const double lock = v * (kLockPeriods * period_s + filter_s);
  const double run_up = 0.5 * (range.base_rate + v) * s.acceleration_s + lock;
  const double run_down = 0.5 * (range.base_rate + v) * s.deceleration_s + lock;
  const double start = r.from_rad - dir * run_up;
  const double end = r.to_rad + dir * run_down;
  if (std::min(start, end) < safety.travel_min_rad ||
      std::max(start, end) > safety.travel_max_rad) {
    throw out_of_limits(
        (std::min(start, end) < safety.travel_min_rad) == (dir > 0) ? wire_key::from_rad
                                                                    : wire_key::to_rad,
        fmt::format("the scan with its run-up and run-down reaches [{:.5g}, {:.5g}] rad, outside "
                    "axis {}'s travel window [{:g}, {:g}] rad (safety.travel_min_rad, "
                    "safety.travel_max_rad)",
                    std::min(start, end), std::max(start, end), axis.name(), safety.travel_min_rad,
                    safety.travel_max_rad));
  }
  // The approach: a move to the run-up's start, from either side (the
  // run-up takes up what the arrival left), within a tenth of the run-up.
  protocol::MoveToRequest approach;
  approach.move.target_rad = start;
  approach.move.tolerance_rad =
      std::clamp(kApproachShareOfRunUp * run_up,
                 std::max(approach.move.tolerance_rad,
                          kApproachToleranceFactor * smallest_tolerance_rad(cal.noise_m, s.r2_m)),
                 firmware::find_move_field(wire_key::tolerance_rad)->allowed.max);
  approach.V0 = cal.V0;
  bool calibrated = false;
  s.approach = plan_move(axis, approach, calibrated);
  s.zero_displacement_m = s.approach.zero_displacement_m;
  if (!std::isfinite(s.zero_displacement_m)) {
    // The angles of A, B and every trigger position are from the zero.
    throw ProtocolError(code::bad_state, wire_key::axis,
                        fmt::format("scan: axis {} has no zero and its sensor gave no reading "
                                    "at rest to take one from",
                                    axis.name()));
  }
  // Triggers: position compare on the filtered angle.
  account.triggers.reset();
  if (r.trigger_step_rad) {
    const double step = *r.trigger_step_rad;
    if (!rig_.lines->has_trigger(axis.index)) {
      throw ProtocolError(
          code::bad_argument, args::trigger_step_rad.name,
          fmt::format("scan: trigger_step_rad: axis {} has no trigger line (the board's [lines] "
                      "backend {} wires none for it)",
                      axis.name(), board_.lines.backend()));
    }
    const std::optional<double> noise_m =
        cal.noise_m > 0.0 ? std::optional(cal.noise_m) : axis.rest.noise_m();
    if (noise_m) {
      const double smallest = kStepOverPeakToPeak * kPeakToPeakOverSigma * *noise_m / s.r2_m;
      if (!(step >= smallest)) {
        throw out_of_limits(
            args::trigger_step_rad.name,
            fmt::format("{:g} rad is under 5 times the sensor's peak-to-peak noise ({:.3g} rad, "
                        "6 x {:.3g} m over {:g} m); allowed: at least {:.4g} rad",
                        step, kPeakToPeakOverSigma * *noise_m / s.r2_m, *noise_m, s.r2_m,
                        smallest));
      }
    }
    firmware::CompareSettings& t = s.compare;
    t.start_rad = r.trigger_start_rad.value_or(r.from_rad);
    t.step_rad = step;
    t.direction = dir;
    t.pre_start_rad = r.trigger_pre_start_rad.value_or(0.0);
    t.width_s = r.trigger_width_s.value_or(kDefaultWidth_s);
    if (dir * (t.start_rad - r.from_rad) < 0.0 || dir * (t.start_rad - r.to_rad) > 0.0) {
      throw out_of_limits(args::trigger_start_rad.name,
                          fmt::format("{:g} rad; allowed: from from_rad to to_rad ({:g} .. {:g})",
                                      t.start_rad, r.from_rad, r.to_rad));
    }
    // The pulses up to the end (B unless given): floor(|end - start| /
    // step) + 1, a rounding's worth of slack so that a span of whole steps
    // ends on a pulse.
    if (r.trigger_end_rad && r.trigger_pulses) {
      throw ProtocolError(
          code::bad_argument, args::trigger_end_rad.name,
          "scan: trigger_end_rad: give trigger_pulses or trigger_end_rad, not both");
    }
    const double last = r.trigger_end_rad.value_or(r.to_rad);
    if (dir * (last - t.start_rad) < 0.0 || dir * (last - r.to_rad) > 0.0) {
      throw out_of_limits(args::trigger_end_rad.name,
                          fmt::format("{:g} rad; allowed: from the start ({:g}) to to_rad ({:g})",
                                      last, t.start_rad, r.to_rad));
    }
    const auto up_to = [&](double position) {
      return static_cast<std::uint64_t>(
                 std::floor(std::abs(position - t.start_rad) / step * (1.0 + 1e-12) + 1e-9)) +
             1;
    };
    const std::uint64_t fit = up_to(r.to_rad);
    const std::uint64_t pulses = r.trigger_pulses.value_or(up_to(last));
    if (pulses > fit || !args::trigger_pulses.allowed.admits(static_cast<double>(pulses))) {
      throw out_of_limits(args::trigger_pulses.name,
                          fmt::format("{}; allowed: 1 to {} (positions up to to_rad)", pulses,
                                      std::min<std::uint64_t>(fit, 1'000'000)));
    }
    t.pulses = static_cast<std::uint32_t>(pulses);
    const double tick_s = 1.0 / board_.drive_rate_hz;
    if (t.width_s < 2.0 * tick_s) {
      throw out_of_limits(args::trigger_width_s.name,
                          fmt::format("{:g} s; allowed: at least {:g} s (two drive ticks)",
                                      t.width_s, 2.0 * tick_s));
    }
    s.triggers = true;
    s.lines = rig_.lines;
    s.axis = axis.index;
    account.triggers = protocol::ScanAccount::Triggers{
        t.start_rad, t.step_rad, t.width_s, t.pre_start_rad, t.pulses, 0, 0, 0};
  }
  account.axis = axis.name();
  account.from_rad = s.from_rad;
  account.to_rad = s.to_rad;
  account.velocity_rad_per_s = v;
  account.acceleration_s = s.acceleration_s;
  account.deceleration_s = s.deceleration_s;
  account.run_up_from_rad = start;
  account.zero_displacement_m = s.zero_displacement_m;
  account.stage = to_string(firmware::ScanStage::approach);
  // Its run: the approach's timeout, then the cruise at the base rate at
  // worst over the run-up, at v (and half as fast again) over the rest.
  const double cruise_s = s.acceleration_s + s.deceleration_s +
                          1.5 * (run_up + std::abs(r.to_rad - r.from_rad) + run_down) / v + 1.0;
  duration_s = s.approach.timeout_s + cruise_s;
  return s;
}

void Daemon::take_pulses(Run& run) {
  for (const auto& part : run.parts) {
    if (!part->scan) continue;
    firmware::TriggerPulse p;
    while (part->scan->pulses().try_pop(p)) {
      protocol::TriggerPulse pulse{p.k,         p.position_rad,
                                   p.angle_rad, 1e-9 * static_cast<double>(p.reading_ns - run.t0),
                                   p.edge_s,    p.late};
      part->pulses.push_back(pulse);
      const protocol::TriggerEvent e{board_id_, run.id, part->axis.name(), pulse};
      const std::string body = protocol::encode_map(e);
      std::array<zmq::const_buffer, 2> frames{zmq::buffer(protocol::topic::trigger),
                                              zmq::buffer(body)};
      (void)zmq::send_multipart(stream_, frames, zmq::send_flags::dontwait);
    }
  }
}

std::vector<protocol::ScanAccount> Daemon::scan_accounts(const Run& run) const {
  std::vector<protocol::ScanAccount> out;
  for (std::size_t i = 0; i < run.parts.size(); ++i) {
    if (run.parts[i]->scan) out.push_back(scan_account(run, i, false));
  }
  return out;
}

protocol::ScanAccount Daemon::scan_account(const Run& run, std::size_t part,
                                           bool with_pulses) const {
  const Run::Part& p = *run.parts[part];
  const firmware::ScanController& scan = *p.scan;
  const firmware::ScanSettings& s = scan.settings();
  protocol::ScanAccount a = p.scan_taken;
  a.stage = to_string(scan.stage());
  const double position = scan.position_rad();
  const double zero = s.zero_displacement_m;
  if (run.finished && p.final_displacement_m && !std::isnan(zero)) {
    a.position_rad = (*p.final_displacement_m - zero) / s.r2_m;  // measured at 0 V
  } else if (!std::isnan(position)) {
    a.position_rad = position;
  }
  if (scan.span_measured()) {
    const firmware::ScanMeasured& m = scan.measured();
    a.measured_velocity_rad_per_s = m.velocity_rad_per_s;
    a.ripple_rad_per_s = m.ripple_rad_per_s;
    a.ripple_10_rad_per_s = m.ripple_10_rad_per_s;
    a.mean_f_hz = m.mean_f_hz;
    a.mean_V = m.mean_fraction * s.V0;
    a.model_velocity_rad_per_s = p.model_velocity_rad_per_s;
  }
  if (a.triggers) {
    a.triggers->fired = scan.pulses_fired();
    a.triggers->late = scan.pulses_late();
    a.triggers->unreported = scan.pulses_unreported();
  }
  if (with_pulses) a.pulses = p.pulses;
  if (run.finished) {
    a.stop_cause =
        firmware::move_end(scan.stage() == firmware::ScanStage::done, run.runner->cause(part));
  }
  return a;
}

void Daemon::end_scans(Run& run) {
  for (const auto& part : run.parts) {
    if (!part->scan) continue;
    // A stop may have come while a pulse was high; the loop has ended.
    part->scan->release_line();
    const firmware::ScanController& scan = *part->scan;
    if (!scan.span_measured() || scan.measured().mean_f_hz <= 0.0) continue;
    // The model beside the measurement: its mean velocity at the drive
    // the board chose over the span (ten periods from rest).
    const firmware::ScanMeasured& m = scan.measured();
    const firmware::ScanSettings& s = scan.settings();
    const double dir = s.to_rad >= s.from_rad ? 1.0 : -1.0;
    const double periods_s = 10.0 / m.mean_f_hz;
    const model::Sawtooth drive(m.mean_fraction * s.V0, m.mean_f_hz, dir > 0 ? s.D : 1.0 - s.D);
    part->model_velocity_rad_per_s = dir *
                                     model::final_angle(part->axis.config.model.motor, drive,
                                                        model::FrictionModel::lugre, periods_s) /
                                     periods_s;
  }
}

}  // namespace piezo::daemon
