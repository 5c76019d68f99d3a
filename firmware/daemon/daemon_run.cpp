// A run's life on the board: configure, start (step), stop, the lease, and
// how its end is taken.

#include "daemon_run.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "calibration.hpp"
#include "piezo/firmware/request_arguments.hpp"
#include "piezo/firmware/request_limits.hpp"
#include "piezo/firmware/wire_keys.hpp"
#include "piezo/protocol/message.hpp"

namespace piezo::daemon {
namespace {

using nlohmann::json;
using protocol::ProtocolError;
namespace code = protocol::code;
using Clock = std::chrono::steady_clock;

// Samples published but not yet acknowledged by the controller's lease
// renewals hold the virtual clock back past this share of the recorder, or
// past this many seconds of drive samples: the host acknowledges what it
// has logged, so its memory holds at most that much not yet written.
constexpr double kVirtualAckWindow = 0.5;
constexpr double kVirtualAckWindow_s = 20.0;

}  // namespace

// The command table has admitted only the controller to these handlers
// while a run is under way (Caller::controller); they do not ask again.

json Daemon::configure(const json& args) {
  if (running()) throw ProtocolError(code::bad_state, "", "configure: a run is under way");
  const auto taken = apply_configuration(
      axis_of(args, "configure"), protocol::decode<protocol::ConfigureRequest>(args), "configure");
  return protocol::ConfigureReply{taken.drive.D(), taken};
}

protocol::ConfigureRequest Daemon::apply_configuration(ServedAxis& axis,
                                                       const protocol::ConfigureRequest& r,
                                                       const char* cmd) {
  if (running())
    throw ProtocolError(code::bad_state, "", fmt::format("{}: a run is under way", cmd));
  if (const auto breach = firmware::check_drive(
          r.drive, r.duration_s,
          {axis.config.drive.limits, board_.drive_rate_hz, board_.daemon.duration_max_s})) {
    throw out_of_limits(breach->key, breach->message);
  }
  configured_ = r;
  configured_axis_ = &axis;
  return r;
}

void Daemon::require_no_axis_fault(const ServedAxis& axis, const char* cmd) const {
  if (axis.fault == firmware::StopCause::none) return;
  throw ProtocolError(code::fault_latched, std::string(wire_key::axis),
                      fmt::format("{}: axis {}: its fault {} is latched; send reset_fault first",
                                  cmd, axis.name(), firmware::to_string(axis.fault)));
}

protocol::StartReply Daemon::start(const std::string& client,
                                   std::optional<double> requested_lease_s, const Program& program,
                                   const char* cmd) {
  run_state_.require_can_start(client, cmd);
  if (!configured_) {
    throw ProtocolError(code::bad_state, "", fmt::format("{}: send configure first", cmd));
  }
  const double lease_s = requested_lease_s.value_or(board_.daemon.lease_s);
  if (const Interval allowed = firmware::arguments::lease_s.within(board_.daemon.lease_max_s);
      !allowed.admits(lease_s)) {
    throw out_of_limits(wire_key::lease_s,
                        fmt::format("{:g} s; allowed: {} s", lease_s, allowed.text()));
  }
  if (program.moves.empty() && program.scans.empty() && !program.calibration) {
    require_inward(*configured_axis_, configured_->drive.direction);
  }
  // The run's loops own the sensors from here: no idle reading runs.
  IdleReader::Hold sensors_held = idle_->hold();
  run_.reset();  // the last run's runner (joined) goes; its samples are overwritten below
  // A move's or a scan's axes (a group's several), or the axis `configure` set.
  std::vector<ServedAxis*> axes;
  for (const Program::Move& m : program.moves) axes.push_back(m.axis);
  for (const Program::Scan& s : program.scans) axes.push_back(s.axis);
  if (axes.empty()) axes.push_back(configured_axis_);
  for (const ServedAxis* axis : axes) require_no_axis_fault(*axis, cmd);
  auto run = std::make_unique<Run>(*configured_, axes);
  run->id = ++run_count_;
  run->lease_s = lease_s;
  samples_.clear();
  build_runner(*run, program);
  const bool virtual_clock = board_.virtual_clock();
  run->lease_renewed_ns = steady_ns();
  std::function<bool()> lagging;
  if (virtual_clock) {
    // Time waits for a controller that is alive but behind.
    Run* r = run.get();
    const auto window = static_cast<std::uint64_t>(
        std::min(kVirtualAckWindow * static_cast<double>(samples_.drive_capacity()),
                 kVirtualAckWindow_s * board_.drive_rate_hz));
    const auto lease_ns = static_cast<std::int64_t>(lease_s * 1e9);
    lagging = [r, window, lease_ns] {
      return steady_ns() - r->lease_renewed_ns.load() < lease_ns &&
             r->drive_recorded.load() > r->drive_acked.load() + window;
    };
  }
  // The lease counts from the time origin, fixed once the loops are set up:
  // the real-time set-up (mlockall, thread priorities) may take longer than
  // a lease on a slow board, and the client renews only once it has the
  // start's reply.
  Run* starting = run.get();
  run->t0 = run->runner->start(
      [this, starting, virtual_clock, lease_s](hal::TimeNs t0) {
        rig_.start_at(t0);
        starting->lease_renewed_ns = steady_ns();
        if (!virtual_clock) starting->remote.lease_deadline = t0 + hal::from_seconds(lease_s);
      },
      lagging);
  run_ = std::move(run);
  run_hold_.emplace(std::move(sensors_held));
  run_state_.started(client);
  log_event(fmt::format("run {} started: V0 {:g} V, f {:g} Hz, {:g} s, lease {:g} s", run_->id,
                        run_->request.drive.V0, run_->request.drive.f, run_->request.duration_s,
                        lease_s));
  publish_state();
  protocol::StartReply started;
  started.run = run_->id;
  started.t0_ns = run_->t0;
  started.lease_s = lease_s;
  started.duration_s = run_->request.duration_s;
  return started;
}

void Daemon::build_runner(Run& run, const Program& program) {
  // The rates are the board's (one tick for every axis).
  firmware::LoopRunnerSettings settings{
      {board_.drive_rate_hz, run.request.duration_s, board_.fault_stops_all},
      board_.sensor_rate_hz,
      !board_.virtual_clock(),
      board_.run.priority,
      board_.run.lock_memory};
  // Each part's axis: its devices, limits, safety, geometry and zero.
  const auto run_axis = [&](Run::Part& part, firmware::DriveProgram& program_to_follow,
                            double period_s, firmware::TravelHeading heading) {
    const ServedAxis& axis = part.axis;
    const config::AxisConfig& c = axis.config;
    return firmware::RunAxis{*axis.rig.drive,
                             *axis.rig.sensor,
                             program_to_follow,
                             c.drive.limits,
                             period_s,
                             c.safety,
                             c.sensor.r2_m,
                             axis.zero.displacement_m(),
                             &part.feed,
                             static_cast<std::uint8_t>(axis.index),
                             heading};
  };
  const auto start_loops = [&](std::vector<firmware::RunAxis> axes) {
    run.runner = std::make_unique<firmware::LoopRunner>(settings, std::move(axes), *rig_.clock,
                                                        *rig_.lines, &run.remote);
  };
  if (!program.moves.empty()) {
    std::vector<firmware::RunAxis> axes;
    for (std::size_t i = 0; i < program.moves.size(); ++i) {
      Run::Part& part = *run.parts[i];
      const firmware::MoveSettings& m = program.moves[i].settings;
      part.move = std::make_unique<firmware::MoveController>(m, part.feed);
      axes.push_back(run_axis(part, *part.move, 1.0 / m.f, program.moves[i].heading));
    }
    start_loops(std::move(axes));
    return;
  }
  if (!program.scans.empty()) {
    std::vector<firmware::RunAxis> axes;
    for (std::size_t i = 0; i < program.scans.size(); ++i) {
      Run::Part& part = *run.parts[i];
      const firmware::ScanSettings& s = program.scans[i].settings;
      part.scan = std::make_unique<firmware::ScanController>(s, part.feed);
      axes.push_back(run_axis(part, *part.scan, 1.0 / s.approach.f, program.scans[i].heading));
    }
    start_loops(std::move(axes));
    return;
  }
  Run::Part& part = run.first();
  ServedAxis& axis = part.axis;
  const config::AxisConfig& c = axis.config;
  const double period_s = 1.0 / run.request.drive.f;
  const firmware::TravelHeading waveform_heading =
      heading(axis, run.request.drive.direction == model::Direction::forward ? 1 : -1,
              run.request.drive.V0);
  if (program.calibration) {
    run.calibration =
        std::make_unique<firmware::CalibrationProgram>(*program.calibration, part.feed);
    // Both ways in turn: no end is behind it.
    start_loops({run_axis(part, *run.calibration, period_s, {})});
  } else if (c.safety.protect_runs) {
    firmware::RunGuardSettings g;
    g.periods = c.safety.stall_periods;
    g.f = run.request.drive.f;
    g.direction = run.request.drive.direction == model::Direction::forward ? 1.0 : -1.0;
    g.r2_m = c.sensor.r2_m;
    const double rad_per_V =
        axis.calibration ? axis.calibration->rad_per_V : c.model.motor.d_e / c.model.motor.r;
    g.stroke_rad = rad_per_V * run.request.drive.V0;
    // The noise at rest, measured now (a few readings before the drive
    // starts), or the calibration's if larger.
    const AtRest rest = read_at_rest(axis, 2 * ServedAxis::kRecentReadings);
    g.noise_m = std::max(rest.good >= 4 ? rest.stddev_m : 0.0,
                         axis.calibration ? axis.calibration->noise_m : 0.0);
    run.guard = std::make_unique<firmware::RunGuard>(run.waveform, g, part.feed);
    start_loops({run_axis(part, *run.guard, period_s, waveform_heading)});
  } else {
    start_loops({run_axis(part, run.waveform_program, period_s, waveform_heading)});
  }
}

firmware::TravelHeading Daemon::heading(const ServedAxis& axis, int direction, double V0) const {
  const config::AxisConfig& c = axis.config;
  const double rad_per_V =
      axis.calibration ? axis.calibration->rad_per_V : c.model.motor.d_e / c.model.motor.r;
  return {direction, rad_per_V * V0};
}

void Daemon::require_inward(const ServedAxis& axis, model::Direction towards) const {
  const int direction = towards == model::Direction::forward ? 1 : -1;
  const std::optional<double> at = position_of(axis).position_rad;
  const firmware::SafetySettings& s = axis.config.safety;
  if (!at) return;  // nowhere known yet: the run's own readings judge it
  const bool past_upper = direction > 0 && *at >= s.travel_max_rad;
  const bool past_lower = direction < 0 && *at <= s.travel_min_rad;
  if (!past_upper && !past_lower) return;
  throw out_of_limits(
      firmware::arguments::direction.name,
      fmt::format("axis {} is at {:.6g} rad, at or past the {} end of its travel window "
                  "[{:g}, {:g}] rad (safety.travel_min_rad, safety.travel_max_rad): only a run "
                  "back inside ({}) is taken",
                  axis.name(), *at, past_upper ? "upper" : "lower", s.travel_min_rad,
                  s.travel_max_rad, past_upper ? "reverse" : "forward"));
}

json Daemon::step(const std::string& client, const json& args) {
  // A step is a run of whole drive periods: each period ends at 0 V (after
  // the fast edge forward, the slow edge in reverse), so the run ends there
  // with nothing left to ramp and the rotor is not pulled back.
  run_state_.require_can_start(client, "step");  // before configure: a refused step changes nothing
  ServedAxis& axis = axis_of(args, "step");
  const auto request = protocol::decode<protocol::StepRequest>(args);
  require_inward(axis, request.drive.direction);
  const double f = request.drive.f;
  // At most the board's longest run of whole periods.
  const Interval allowed =
      firmware::arguments::count.within(std::floor(board_.daemon.duration_max_s * f));
  if (!allowed.admits(static_cast<double>(request.count))) {
    throw out_of_limits(wire_key::count,
                        fmt::format("{} periods at {:g} Hz; allowed: [{:g}, {:g}] (the "
                                    "board's longest run, {:g} s)",
                                    request.count, f, allowed.min, std::max(allowed.max, 0.0),
                                    board_.daemon.duration_max_s));
  }
  const auto configured =
      apply_configuration(axis, {request.drive, static_cast<double>(request.count) / f}, "step");
  protocol::StartReply started = start(client, request.lease_s, Program{}, "step");
  started.count = request.count;
  started.direction = configured.drive.direction;
  return started;
}

json Daemon::stop_run(const json& args) {
  const bool at_once = args.value(wire_key::now, false);
  const char* how = at_once ? " at once" : "";
  const auto named = args.find(wire_key::axis);
  if (named == args.end() || named->is_null()) {
    if (running()) {
      run_->runner->request_stop(at_once);
      log_event(fmt::format("run {}: stop{} requested", run_->id, how));
    }
    return protocol::StateReply{run_state_.state()};
  }
  ServedAxis& axis = axis_of(args, "stop");
  if (running()) {
    std::string in_run;
    for (std::size_t i = 0; i < run_->parts.size(); ++i) {
      if (&run_->parts[i]->axis == &axis) {
        run_->runner->request_axis_stop(i, at_once);
        log_event(fmt::format("run {}: stop{} of axis {} requested", run_->id, how, axis.name()));
        return protocol::StateReply{run_state_.state()};
      }
      in_run += (in_run.empty() ? "" : ", ") + run_->parts[i]->axis.name();
    }
    throw ProtocolError(
        code::bad_argument, wire_key::axis,
        fmt::format("stop: axis: {} is not in the run (its axes: {})", axis.name(), in_run));
  }
  return protocol::StateReply{run_state_.state()};
}

json Daemon::estop(const std::string& client) {
  // The enable line drops from this thread at once, where the backend has
  // one, even while the drive loop is blocked in a slow write; the loop then
  // stops itself.
  if (running()) {
    run_->remote.estop.store(true);
    (void)rig_.lines->trip();
  } else {
    run_state_.estop_at_rest();
    publish_state();
  }
  log_event(fmt::format("e-stop from a client{}",
                        run_state_.is_controller(client) ? " (the controller)" : ""));
  return protocol::StateReply{run_state_.state()};
}

json Daemon::reset_fault() {
  // A hardware e-stop's latch is the board's own (the lines hold the
  // amplifier off): it clears only once the button is released.
  if (!running() && !rig_.lines->reset_estop()) {
    throw ProtocolError(code::bad_state, "",
                        "reset_fault: the e-stop button is still pressed (or its line cannot be "
                        "read); release it first");
  }
  const auto cleared = run_state_.reset();
  bool axis_cleared = false;
  for (const auto& axis : axes_) {
    if (axis->fault == firmware::StopCause::none) continue;
    log_event(
        fmt::format("axis {}: fault {} reset", axis->name(), firmware::to_string(axis->fault)));
    axis->fault = firmware::StopCause::none;
    axis_cleared = true;
  }
  if (cleared != firmware::StopCause::none) {
    log_event(fmt::format("fault {} reset", firmware::to_string(cleared)));
  }
  if (cleared != firmware::StopCause::none || axis_cleared) publish_state();
  return protocol::StateReply{run_state_.state()};
}

json Daemon::renew_lease(const json& args) {
  if (!running()) throw ProtocolError(code::bad_state, "", "lease: no run is under way");
  const auto request = protocol::decode<protocol::LeaseRequest>(args);
  if (request.drive_received) run_->drive_acked = *request.drive_received;
  if (board_.virtual_clock()) {
    run_->lease_renewed_ns = steady_ns();
  } else {
    run_->remote.lease_deadline = rig_.clock->now() + hal::from_seconds(run_->lease_s);
  }
  return protocol::LeaseReply{run_->lease_s};
}

void Daemon::check_lease_on_wall_clock() {
  if (!running() || !board_.virtual_clock()) return;
  if (static_cast<double>(steady_ns() - run_->lease_renewed_ns.load()) > run_->lease_s * 1e9) {
    // Expire it on the board clock, as of now: the drive loop stops with
    // link_lost (unless the run's duration had already ended by then).
    run_->remote.lease_deadline.store(
        std::min(run_->remote.lease_deadline.load(), rig_.clock->now()));
  }
}

void Daemon::pump_samples() {
  if (!run_) return;
  Run& run = *run_;
  take_pulses(run);
  samples_.take(
      *run.runner,
      [&run](const firmware::DriveSample& s) {
        if (Run::Part* part = run.part_of(s.axis)) part->phase = s.phase;
      },
      [this](std::uint8_t axis_index, double d) {
        ServedAxis& axis = *axes_.at(axis_index);
        axis.remember_reading(d);
        axis.last_good_wall_ns = steady_ns();
        axis.zero.offer(d);  // no zero yet: the first good reading
      });
  run.drive_recorded = samples_.drive_recorded();
  // The drive's own phase says when the stop began: once no axis of the
  // run drives any more (an axis of a group that ended on its own is not
  // the board's stop).
  const bool ramping =
      std::all_of(run.parts.begin(), run.parts.end(),
                  [](const auto& part) { return part->phase != firmware::DrivePhase::driving; }) &&
      std::any_of(run.parts.begin(), run.parts.end(), [](const auto& part) {
        return part->phase == firmware::DrivePhase::ramping_down;
      });
  if (ramping && run_state_.ramping()) publish_state();
}

void Daemon::finish_run() {
  auto& run = *run_;
  run.runner->join();
  pump_samples();
  if (run.is_move() || run.is_scan() || run.calibration) {
    for (const auto& part : run.parts) {
      const AtRest rest = read_at_rest(part->axis, ServedAxis::kRecentReadings);
      if (rest.good > 0) part->final_displacement_m = rest.mean_m;
    }
  }
  end_scans(run);
  take_pulses(run);
  run.finished = true;
  const auto cause = run.runner->cause();
  run.summary = summary(run);
  for (const auto& part : run.parts) {
    // A move's own zero, to the last bit, when it took one because its
    // axis had none; a zero acknowledged before the move is never undone.
    if (!part->move) continue;
    if (const double z = part->move->zero_displacement_m();
        part->move_takes_its_zero && !std::isnan(z)) {
      part->axis.zero.set(z);
    }
  }
  if (run.calibration) take_calibration(run);
  const bool confirmed = run.summary.output.state == firmware::OutputState::confirmed;
  // Each axis's end latches where its cause's scope says (RunState::latch_of);
  // an output not confirmed at 0 V latches on the board (RunState::ended).
  bool board_fault = false;
  for (std::size_t i = 0; i < run.parts.size(); ++i) {
    const auto c = run.runner->cause(i);
    switch (RunState::latch_of(c)) {
      case RunState::Latch::on_board:
        board_fault = true;
        break;
      case RunState::Latch::on_axis:
        run.parts[i]->axis.fault = c;
        log_event(fmt::format("axis {}: fault {} latched", run.parts[i]->axis.name(),
                              firmware::to_string(c)));
        break;
      case RunState::Latch::nowhere:
        break;
    }
  }
  run_state_.ended(board_fault ? cause : firmware::StopCause::completed, confirmed);
  log_event(fmt::format(
      "run {} ended: {}, output {}{}", run.id, firmware::to_string(cause),
      firmware::to_string(run.summary.output.state),
      run_state_.state() == State::fault ? " (fault latched: reset_fault to go on)" : ""));
  // A new rest from here: the idle reader reads the sensors again.
  begin_rest();
  run_hold_.reset();
  publish_state();
}

void Daemon::take_calibration(Run& run) {
  const auto cause = run.runner->cause();
  const auto& result = run.calibration->result();
  run.summary.calibration.present = true;  // a calibration run's: nil when it installed none
  if (!result.complete || cause != firmware::StopCause::completed) {
    run.summary.calibration_error =
        fmt::format("the experiment ended {} before it was complete; the board keeps {}",
                    firmware::to_string(cause),
                    run.first().axis.calibration ? "its calibration" : "no calibration");
    return;
  }
  try {
    ServedAxis& axis = run.first().axis;
    const config::DriveSettings& drive = axis.config.drive;
    install_calibration(
        axis, checked_calibration(
                  measured_calibration(run.calibration->plan(), result),
                  {drive.limits.V_max, firmware::max_drive_frequency(board_.drive_rate_hz)}));
    run.summary.calibration.value = *axis.calibration;
  } catch (const std::exception& e) {
    // Measurements no calibration can hold (no motion, a sensor that saw
    // nothing): the old calibration stays; the summary says why.
    run.summary.calibration_error = e.what();
    log_event(fmt::format("calibration not installed: {}", e.what()));
  }
}

}  // namespace piezo::daemon
