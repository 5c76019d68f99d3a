#include "piezo/firmware/drive_loop.hpp"

#include <cmath>
#include <limits>
#include <utility>

namespace piezo::firmware {
namespace {
// A waveform's end within this of 0 V is 0 V (the period's end, up to the
// rounding of t).
constexpr double kOnZero_V = 1e-6;

/// A cause that is an axis's own fault, which fault_stops_all spreads.
[[nodiscard]] bool is_axis_fault(StopCause c) {
  return scope_of(c) == CauseScope::axis;
}
}  // namespace

DriveLoop::DriveLoop(const DriveLoopSettings& settings, std::vector<DriveAxis> axes, DriveLoopIo io)
    : settings_(settings), io_(io) {
  axes_.reserve(axes.size());
  for (const DriveAxis& a : axes) axes_.push_back({a, {}, {}, false, 0});
}

void DriveLoop::emit(Axis& axis, hal::TimeNs t, double V, DrivePhase phase, hal::Status status) {
  if (status != hal::Status::ok) health_.count(health_.errors);
  if (!axis.io.ring->try_push(
          {t, V, phase, status, axis.io.program->state_code(), axis.io.index})) {
    health_.count(health_.dropped_samples);
  }
}

void DriveLoop::count_failure(hal::Status s) {
  if (s != hal::Status::ok) health_.count(health_.errors);
}

bool DriveLoop::all_stopped() const {
  for (const Axis& a : axes_)
    if (!a.stopped) return false;
  return true;
}

void DriveLoop::drop_enable() {
  if (enable_dropped_) return;
  enable_dropped_ = true;
  enable_status_ = io_.lines.set_amplifier_enable(false);
  count_failure(enable_status_);
}

void DriveLoop::stop_axis(Axis& axis, hal::TimeNs t) {
  // The last axis drops the enable first: it is the path that works when
  // the drive does not. Then 0 V, written until the drive acknowledges it
  // or the bound passes; a drive that times out paces the retries itself.
  constexpr hal::TimeNs kRetryPause = 2'000'000;
  axis.stopped = true;
  axis.stop_rank = ++stops_;
  OutputOutcome& o = axis.outcome;
  if (all_stopped()) {
    drop_enable();
    o.enable_status = enable_status_;
  }
  hal::Drive& drive = *axis.io.drive;
  const hal::TimeNs give_up =
      io_.clock.now() + hal::from_seconds(axis.io.supervisor->settings().stop_confirm_s);
  for (;;) {
    o.zero_status = drive.write_now(0.0);
    ++o.zero_writes;
    if (o.zero_status == hal::Status::ok || io_.clock.now() >= give_up) break;
    io_.clock.sleep_until(io_.clock.now() + kRetryPause);
  }
  count_failure(o.zero_status);
  o.zero_confirmed = o.zero_status == hal::Status::ok;
  o.zero_read_back = o.zero_confirmed && drive.reads_back();
  o.acknowledged_V = drive.acknowledged_V();
  // The log holds what the device acknowledged, never a 0 V it did not reach.
  if (o.zero_confirmed) {
    emit(axis, t, 0.0, DrivePhase::stopped, o.zero_status);
  } else {
    emit(axis, t, o.acknowledged_V, DrivePhase::output_unconfirmed, o.zero_status);
    // Its drive no longer answers: only the board's enable still reaches it.
    for (Axis& other : axes_) other.io.supervisor->stop_now(StopCause::other_axis_fault);
    stop_all(t);
  }
  if (all_stopped()) count_failure(io_.lines.set_sync(false));
}

void DriveLoop::stop_all(hal::TimeNs t) {
  drop_enable();
  for (Axis& a : axes_) {
    if (a.stopped) continue;
    a.outcome.enable_status = enable_status_;
    stop_axis(a, t);
  }
}

void DriveLoop::end_tick(bool starting) {
  for (Axis& a : axes_) {
    if (a.stopped) continue;
    const hal::Status sent = a.io.drive->end_tick();
    if (sent == hal::Status::ok) continue;
    if (starting) {
      a.io.supervisor->report_start(sent);
    } else {
      a.io.supervisor->report_drive_write(sent);
    }
  }
}

bool DriveLoop::enable() {
  for (Axis& a : axes_) a.io.supervisor->report_start(a.io.drive->write(0.0));
  end_tick(true);
  const hal::EstopState estop = io_.lines.poll_estop();
  const bool stop = io_.stop_requested.load(std::memory_order_relaxed);
  bool refused = false;
  for (Axis& a : axes_) {
    refused |=
        a.io.supervisor->check(io_.clock.now(), estop, stop, false) == SafetyAction::disable_now;
  }
  // One axis whose drive does not take 0 V keeps the amplifier off for all:
  // nothing is enabled that cannot be stopped.
  if (refused) {
    for (Axis& a : axes_) a.io.supervisor->stop_now(StopCause::other_axis_fault);
    return false;
  }
  for (Axis& a : axes_) a.outcome.enabled_ever = true;
  count_failure(io_.lines.set_amplifier_enable(true));
  return true;
}

SafetyAction DriveLoop::check(Axis& axis, hal::TimeNs now, double t, const hal::EstopState& estop) {
  DriveProgram& program = *axis.io.program;
  if (const StopCause fault = program.fault(); fault != StopCause::none) {
    axis.io.supervisor->report_program_fault(fault);
  }
  const auto requested = [](const std::atomic<bool>& board, const std::atomic<bool>* own) {
    return board.load(std::memory_order_relaxed) ||
           (own != nullptr && own->load(std::memory_order_relaxed));
  };
  const bool stop = requested(io_.stop_requested, axis.io.stop_requested);
  const bool at_once = requested(io_.stop_now_requested, axis.io.stop_now_requested);
  return axis.io.supervisor->check(now, estop, stop || at_once,
                                   t >= settings_.duration_s || program.finished(), at_once);
}

void DriveLoop::begin_ramp(Axis& axis) {
  axis.out.phase = DrivePhase::ramping_down;
  // A waveform that ran its whole duration ends on its own value there
  // (0 V at a period's end) at the slew limit, as its own edges go, instead
  // of ramping from its last sample: a step's fast edge stays fast, also
  // when missed deadlines left the drive behind it.
  const double end = axis.io.program->end_voltage(settings_.duration_s);
  if (axis.io.supervisor->cause() == StopCause::completed && std::isfinite(end)) {
    axis.out.end_V = std::abs(end) < kOnZero_V ? 0.0 : end;
  }
}

double DriveLoop::next_value(Axis& axis, double t, double dt) {
  // Each step is bounded as the hardware applies it, within about one
  // update period: after a stall the drive catches up at the slew limit
  // instead of jumping by all the time it lost.
  Output& out = axis.out;
  const VoltageLimits& limits = axis.io.limits;
  if (out.phase == DrivePhase::driving) {
    return limit_voltage(limits, axis.io.program->next_voltage(t, dt), out.V, dt);
  }
  if (!std::isnan(out.end_V)) {
    const double V = limit_voltage(limits, out.end_V, out.V, dt);
    if (std::abs(V - out.end_V) >= kOnZero_V) return V;
    const double end = out.end_V;
    out.end_V = std::numeric_limits<double>::quiet_NaN();  // 0 V stops; else the ramp goes on
    return end;
  }
  return step_towards(out.V, 0.0, axis.io.supervisor->settings().ramp_down_V_per_s, dt);
}

bool DriveLoop::drive_axis(Axis& axis, hal::TimeNs deadline, hal::TimeNs now, double t, double dt,
                           const hal::EstopState& estop) {
  const SafetyAction action = check(axis, now, t, estop);
  if (action == SafetyAction::disable_now) {
    stop_axis(axis, deadline);  // instead of this deadline's value
    return true;
  }
  Output& out = axis.out;
  if (action == SafetyAction::ramp_down && out.phase == DrivePhase::driving) {
    begin_ramp(axis);
    // A waveform that completes on its own 0 V (a step's whole periods)
    // and is there within this update has nothing to ramp: it stops on
    // this deadline, and no record or state says ramping_down. Its
    // samples are the driven ones; the stop record follows them.
    if (out.end_V == 0.0 && std::abs(limit_voltage(axis.io.limits, 0.0, out.V, dt)) == 0.0) {
      stop_axis(axis, deadline);
      return false;
    }
  }
  out.V = next_value(axis, t, dt);
  const hal::Status written = axis.io.drive->write(out.V);
  axis.io.supervisor->report_drive_write(written);
  emit(axis, deadline, out.V, out.phase, written);
  if (out.phase == DrivePhase::ramping_down && out.V == 0.0) {
    // The stop record belongs to the grid too: the next deadline.
    stop_axis(axis, deadline + hal::from_seconds(dt));
  }
  return true;
}

void DriveLoop::tell_neighbours_stepping(double t) {
  int stepping = 0;
  for (const Axis& a : axes_) stepping += !a.stopped && a.io.program->stepping() ? 1 : 0;
  for (Axis& a : axes_) {
    if (a.stopped) continue;
    const int own = a.io.program->stepping() ? 1 : 0;
    a.io.program->set_neighbours_stepping(stepping - own > 0, t);
  }
}

void DriveLoop::spread_faults() {
  if (!settings_.fault_stops_all) return;
  for (const Axis& a : axes_) {
    if (!is_axis_fault(a.io.supervisor->cause())) continue;
    for (Axis& other : axes_) {
      if (&other != &a) other.io.supervisor->report_program_fault(StopCause::other_axis_fault);
    }
    return;
  }
}

void DriveLoop::update_sync(double t) {
  const Axis& first = axes_.front();
  const auto waveform_period = static_cast<long>(std::floor(t / first.io.period_s));
  const bool want_sync = !first.stopped && first.out.phase == DrivePhase::driving &&
                         waveform_period != last_sync_period_;
  last_sync_period_ = waveform_period;
  if (want_sync != sync_high_) {
    count_failure(io_.lines.set_sync(want_sync));
    sync_high_ = want_sync;
  }
}

void DriveLoop::count_lateness(hal::TimeNs deadline, hal::TimeNs period) {
  // `deadline` is a copy: the loop keeps its own and catches up, writing each
  // passed deadline's value (a card's clocked output queues every tick);
  // here they are only counted.
  const hal::TimeNs done = io_.clock.now();
  if (done > deadline) {
    health_.count(health_.overruns);
    health_.count(health_.missed_cycles, skip_missed(deadline, done, period));
  }
}

StopCause DriveLoop::run_cause() const {
  // The first axis to stop for anything but its end names the run's end
  // (an e-stop names every axis's); a run whose axes all completed completed.
  const Axis* first = nullptr;
  for (const Axis& a : axes_) {
    const StopCause c = a.io.supervisor->cause();
    if (c != StopCause::completed && c != StopCause::other_axis_fault &&
        (first == nullptr || a.stop_rank < first->stop_rank)) {
      first = &a;
    }
  }
  return first != nullptr ? first->io.supervisor->cause() : axes_.front().io.supervisor->cause();
}

StopCause DriveLoop::run(hal::TimeNs t0) {
  const auto period = hal::from_seconds(1.0 / settings_.rate_hz);
  const double dt = 1.0 / settings_.rate_hz;
  // Enable only once every drive holds 0 V and the e-stop has been looked at.
  if (!enable()) {
    stop_all(t0);
    return run_cause();
  }
  hal::TimeNs deadline = t0;
  for (;;) {
    io_.clock.sleep_until(deadline);
    const hal::TimeNs now = io_.clock.now();
    health_.period_error.record(now - deadline);
    // The value belongs to its deadline: a hardware-timed DAC latches it on
    // the grid, so wake-up jitter must not shift the waveform's phase.
    const double t = hal::to_seconds(deadline - t0);
    const hal::EstopState estop = io_.lines.poll_estop();  // once per tick, for every axis
    bool cycle = false;
    tell_neighbours_stepping(t);
    for (Axis& axis : axes_) {
      if (!axis.stopped) cycle |= drive_axis(axis, deadline, now, t, dt, estop);
    }
    end_tick(false);
    if (cycle) health_.count(health_.cycles);
    if (all_stopped()) return run_cause();
    spread_faults();
    update_sync(t);
    deadline += period;
    count_lateness(deadline, period);
  }
}

}  // namespace piezo::firmware
