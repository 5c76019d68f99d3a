// What the board says about itself: hello, status and the stream's events,
// built as the protocol's typed messages (piezo/protocol/messages.hpp).

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <zmq_addon.hpp>

#include "calibration.hpp"
#include "daemon_run.hpp"
#include "piezo/firmware/wire_keys.hpp"
#include "piezo/protocol/frame.hpp"
#include "piezo/protocol/message.hpp"
#include "piezo/protocol/topics.hpp"

namespace piezo::daemon {
namespace {

using nlohmann::json;

protocol::LoopHealth health_of(const firmware::LoopHealth& h, bool with_timing) {
  protocol::LoopHealth m{h.cycles.load(),          h.overruns.load(), h.missed_cycles.load(),
                         h.dropped_samples.load(), h.errors.load(),   std::nullopt};
  if (with_timing) {
    // The histogram's counters may be read while the loop runs.
    const auto bins = h.period_error.bins();
    std::size_t used = bins.size();
    while (used > 0 && bins[used - 1] == 0) --used;
    m.timing = protocol::LoopHealth::Timing{
        h.period_error.quantile_us(0.5), h.period_error.quantile_us(0.99), h.period_error.max_us(),
        h.period_error.mean_us(),
        std::vector<double>(bins.begin(), bins.begin() + static_cast<long>(used))};
  }
  return m;
}

}  // namespace

protocol::Hello Daemon::hello() const {
  protocol::Hello h;
  h.protocol = protocol::kProtocolVersion;
  h.board_id = board_id_;
  h.frame_version = protocol::kFrameVersion;
  h.daemon = PIEZO_VERSION;
  h.stream = stream_endpoint_;
  h.clock = config::name(board_.run.clock);
  h.backends = {std::string(board_.lines.backend())};
  h.drive_rate_hz = board_.drive_rate_hz;
  h.sensor_rate_hz = board_.sensor_rate_hz;
  h.lease_s = board_.daemon.lease_s;
  h.recorder_s = board_.daemon.recorder_s;
  // The board's limits: its own, and the widest of its axes' (each axis
  // checks its own; these bound what the dictionary describes).
  h.limits = {std::numeric_limits<double>::infinity(),
              -std::numeric_limits<double>::infinity(),
              0.0,
              std::numeric_limits<double>::infinity(),
              std::numeric_limits<double>::infinity(),
              firmware::max_drive_frequency(board_.drive_rate_hz),
              board_.daemon.duration_max_s,
              board_.daemon.lease_max_s};
  const auto end = [](double v) { return std::isfinite(v) ? std::optional(v) : std::nullopt; };
  for (const auto& axis : axes_) {
    const config::AxisConfig& a = axis->config;
    h.limits.V_min = std::min(h.limits.V_min, a.drive.limits.V_min);
    h.limits.V_max = std::max(h.limits.V_max, a.drive.limits.V_max);
    h.limits.slew_V_per_s = std::max(h.limits.slew_V_per_s, a.drive.limits.slew_V_per_s);
    h.limits.ramp_down_V_per_s = std::min(h.limits.ramp_down_V_per_s, a.safety.ramp_down_V_per_s);
    h.limits.sensor_stale_s = std::min(h.limits.sensor_stale_s, a.safety.sensor_stale_s);
    h.output_latency_s = std::max(h.output_latency_s, axis->rig.drive->output_latency_s());
    h.axes.push_back({a.name, a.sensor.r2_m, a.drive.limits.V_min, a.drive.limits.V_max,
                      a.drive.limits.slew_V_per_s, end(a.safety.travel_min_rad),
                      end(a.safety.travel_max_rad), std::string(a.drive.backend()),
                      std::string(a.sensor.backend()), axis->zero.value(), axis->calibration,
                      std::nullopt, std::nullopt, false});
    if (axis->calibration) {
      const VelocityRange range = velocity_range(*axis->calibration);
      if (range.top > 0.0) {
        h.axes.back().velocity_max_rad_per_s = range.top;
        h.axes.back().base_rate_rad_per_s = range.base_rate;
      }
    }
    h.axes.back().trigger = rig_.lines->has_trigger(axis->index);
  }
  return h;
}

protocol::Status::Position Daemon::position_of(const ServedAxis& axis) const {
  protocol::Status::Position p;
  const auto last = axis.recent_displacement_m();
  if (axis.zero.known() && last)
    p.position_rad = axis.zero.angle_rad(*last, axis.config.sensor.r2_m);
  p.zero_displacement_m = axis.zero.value();
  return p;
}

protocol::Status Daemon::status(const std::string& client) const {
  protocol::Status s;
  s.board_id = board_id_;
  s.state = run_state_.state();
  s.board_ns = rig_.clock->now();
  s.controller = run_state_.is_controller(client);
  s.controlled = run_state_.controlled();
  s.requests = command_table_.counts();
  if (run_state_.state() == State::fault) s.fault = run_state_.fault();
  s.recorder = {{samples_.drive_first(), samples_.drive_recorded()},
                {samples_.sensor_first(), samples_.sensor_recorded()}};
  for (const auto& axis : axes_) {
    s.axes.push_back(
        {axis->name(), position_of(*axis), axis->calibration.has_value(),
         axis->fault == firmware::StopCause::none ? std::nullopt : std::optional(axis->fault),
         rest_of(*axis)});
  }
  s.configured = configured_;
  if (run_) {
    protocol::RunStatus r;
    r.id = run_->id;
    for (const auto& part : run_->parts) r.axes.push_back(part->axis.name());
    r.t0_ns = run_->t0;
    r.duration_s = run_->request.duration_s;
    r.lease_s = run_->lease_s;
    r.finished = run_->finished;
    r.drive = health_of(run_->runner->drive_health(), false);
    r.sensor = health_of(run_->runner->sensor_health(), false);
    if (run_->finished) r.summary = run_->summary;
    if (run_->is_move()) r.moves = move_accounts(*run_);
    if (run_->is_scan()) r.scans = scan_accounts(*run_);
    if (run_->calibration) r.calibration_progress = run_->calibration->progress();
    s.run = r;
  }
  return s;
}

std::vector<protocol::MoveAccount> Daemon::move_accounts(const Run& run) const {
  std::vector<protocol::MoveAccount> out;
  if (!run.is_move()) return out;
  for (std::size_t i = 0; i < run.parts.size(); ++i) out.push_back(move_account(run, i));
  return out;
}

protocol::MoveAccount Daemon::move_account(const Run& run, std::size_t part) const {
  const Run::Part& p = *run.parts[part];
  const firmware::MoveController& m = *p.move;
  const double zero = m.zero_displacement_m();
  // On target, the settle's mean (read at 0 V, of as many readings as the
  // noise asks for); any other end, the readings taken after the stop.
  const bool on_target = m.state() == firmware::MoveState::on_target;
  const double position = !on_target && p.final_displacement_m && !std::isnan(zero)
                              ? (*p.final_displacement_m - zero) / m.settings().r2_m
                              : m.position_rad();
  const auto finite = [](double v) { return std::isnan(v) ? std::nullopt : std::optional(v); };
  protocol::MoveAccount a;
  a.axis = p.axis.name();
  a.state = m.state();
  a.target_rad = m.settings().target_rad;
  a.tolerance_rad = m.settings().tolerance_rad;
  a.position_rad = finite(position);
  a.error_rad = finite(m.settings().target_rad - position);
  a.on_target = on_target;
  if (on_target) a.on_target_at_s = m.on_target_at_s();
  a.steps = m.steps();
  a.f_hz = m.f_hz();
  a.noise_m = finite(m.noise_m());
  if (m.settings().hold_s > 0.0) {
    a.hold = protocol::MoveAccount::Hold{m.settings().hold_s, finite(m.hold_rms_error_rad()),
                                         finite(m.hold_max_error_rad())};
  }
  // Once the loops have ended (their causes are theirs until then): each
  // axis ends on its own.
  if (run.finished) a.stop_cause = firmware::move_end(on_target, run.runner->cause(part));
  return a;
}

namespace {

protocol::OutputEnd output_end(const firmware::OutputOutcome& out) {
  return {firmware::output_state(out),
          out.zero_confirmed,
          out.zero_read_back,
          std::isnan(out.acknowledged_V) ? std::nullopt : std::optional(out.acknowledged_V),
          out.zero_writes,
          std::string(hal::to_string(out.zero_status)),
          out.enabled_ever,
          std::string(hal::to_string(out.enable_status))};
}

}  // namespace

protocol::RunSummary Daemon::summary(const Run& run) const {
  protocol::RunSummary s;
  s.cause = run.runner->cause();
  // The run's output is every axis's: confirmed only when each is (the
  // first unconfirmed one's otherwise).
  s.output = output_end(run.runner->outcome(0));
  for (std::size_t i = 0; i < run.parts.size(); ++i) {
    const protocol::OutputEnd out = output_end(run.runner->outcome(i));
    if (s.output.state == firmware::OutputState::confirmed) s.output = out;
    protocol::RunSummary::Axis axis{run.parts[i]->axis.name(), run.runner->cause(i), out,
                                    std::nullopt, std::nullopt};
    if (run.is_move()) axis.move = move_account(run, i);
    if (run.is_scan()) axis.scan = scan_account(run, i, true);
    s.axes.push_back(std::move(axis));
  }
  s.drive = health_of(run.runner->drive_health(), true);
  s.sensor = health_of(run.runner->sensor_health(), true);
  s.realtime = run.runner->realtime_notes();
  s.samples = {samples_.drive_recorded(), samples_.sensor_recorded()};
  return s;
}

void Daemon::publish_state() {
  protocol::StateEvent e;
  e.state = run_state_.state();
  e.board_ns = rig_.clock->now();
  if (run_) e.run = run_->id;
  if (run_state_.state() == State::fault) e.fault = run_state_.fault();
  if (run_ && run_->finished) e.summary = run_->summary;
  const std::string body = protocol::encode_map(e);
  std::array<zmq::const_buffer, 2> parts{zmq::buffer(protocol::topic::state), zmq::buffer(body)};
  (void)zmq::send_multipart(stream_, parts, zmq::send_flags::dontwait);
}

void Daemon::publish_health() {
  protocol::HealthEvent e;
  e.board_id = board_id_;
  e.state = run_state_.state();
  e.board_ns = rig_.clock->now();
  if (running()) {
    e.drive = health_of(run_->runner->drive_health(), true);
    e.sensor = health_of(run_->runner->sensor_health(), true);
    if (run_->is_move()) e.moves = move_accounts(*run_);
    if (run_->is_scan()) e.scans = scan_accounts(*run_);
    if (run_->calibration) e.calibration_progress = run_->calibration->progress();
  }
  for (const auto& axis : axes_) e.rest.push_back(rest_of(*axis));
  const std::string body = protocol::encode_map(e);
  std::array<zmq::const_buffer, 2> parts{zmq::buffer(protocol::topic::health), zmq::buffer(body)};
  (void)zmq::send_multipart(stream_, parts, zmq::send_flags::dontwait);
}

}  // namespace piezo::daemon
