#include "piezo/firmware/drive_loop.hpp"

#include <cmath>
#include <limits>

namespace piezo::firmware {

DriveLoop::DriveLoop(const DriveLoopSettings& settings, DriveProgram& program,
                     SafetySupervisor& supervisor, DriveLoopIo io)
    : settings_(settings), program_(program), supervisor_(supervisor), io_(io) {}

void DriveLoop::emit(hal::TimeNs t, double V, DrivePhase phase, hal::Status status) {
  if (status != hal::Status::ok) health_.count(health_.errors);
  if (!io_.ring.try_push({t, V, phase, status, program_.state_code()})) {
    health_.count(health_.dropped_samples);
  }
}

void DriveLoop::count_failure(hal::Status s) {
  if (s != hal::Status::ok) health_.count(health_.errors);
}

void DriveLoop::stop_output(hal::TimeNs t) {
  // The enable drops first: it is the path that works when the drive does
  // not. Then 0 V, written until the drive acknowledges it or the bound
  // passes; a drive that times out paces the retries itself.
  constexpr hal::TimeNs kRetryPause = 2'000'000;
  outcome_.enable_status = io_.lines.set_amplifier_enable(false);
  count_failure(outcome_.enable_status);
  const hal::TimeNs give_up =
      io_.clock.now() + hal::from_seconds(supervisor_.settings().stop_confirm_s);
  for (;;) {
    outcome_.zero_status = io_.drive.write_now(0.0);
    ++outcome_.zero_writes;
    if (outcome_.zero_status == hal::Status::ok || io_.clock.now() >= give_up) break;
    io_.clock.sleep_until(io_.clock.now() + kRetryPause);
  }
  count_failure(outcome_.zero_status);
  count_failure(io_.lines.set_sync(false));
  outcome_.zero_confirmed = outcome_.zero_status == hal::Status::ok;
  outcome_.zero_read_back = outcome_.zero_confirmed && io_.drive.reads_back();
  outcome_.acknowledged_V = io_.drive.acknowledged_V();
  // The log holds what the device acknowledged, never a 0 V it did not reach.
  if (outcome_.zero_confirmed) {
    emit(t, 0.0, DrivePhase::stopped, outcome_.zero_status);
  } else {
    emit(t, outcome_.acknowledged_V, DrivePhase::output_unconfirmed, outcome_.zero_status);
  }
}

namespace {
// A waveform's end within this of 0 V is 0 V (the period's end, up to the
// rounding of t).
constexpr double kOnZero_V = 1e-6;
}  // namespace

bool DriveLoop::enable() {
  const hal::Status zeroed = io_.drive.write(0.0);
  supervisor_.report_start(zeroed);
  if (supervisor_.check(io_.clock.now(), io_.lines.poll_estop(),
                        io_.stop_requested.load(std::memory_order_relaxed),
                        false) == SafetyAction::disable_now) {
    return false;
  }
  outcome_.enabled_ever = true;
  count_failure(io_.lines.set_amplifier_enable(true));
  return true;
}

SafetyAction DriveLoop::check(hal::TimeNs now, double t) {
  if (const StopCause fault = program_.fault(); fault != StopCause::none) {
    supervisor_.report_program_fault(fault);
  }
  return supervisor_.check(now, io_.lines.poll_estop(),
                           io_.stop_requested.load(std::memory_order_relaxed),
                           t >= settings_.duration_s || program_.finished());
}

void DriveLoop::begin_ramp(Output& out) {
  out.phase = DrivePhase::ramping_down;
  // A waveform that ran its whole duration ends on its own value there
  // (0 V at a period's end) at the slew limit, as its own edges go, instead
  // of ramping from its last sample: a step's fast edge stays fast, also
  // when missed deadlines left the drive behind it.
  const double end = program_.end_voltage(settings_.duration_s);
  if (supervisor_.cause() == StopCause::completed && std::isfinite(end)) {
    out.end_V = std::abs(end) < kOnZero_V ? 0.0 : end;
  }
}

double DriveLoop::next_value(Output& out, double t, double dt) {
  // Each step is bounded as the hardware applies it, within about one
  // update period: after a stall the drive catches up at the slew limit
  // instead of jumping by all the time it lost.
  if (out.phase == DrivePhase::driving) {
    return limit_voltage(settings_.limits, program_.next_voltage(t, dt), out.V, dt);
  }
  if (!std::isnan(out.end_V)) {
    const double V = limit_voltage(settings_.limits, out.end_V, out.V, dt);
    if (std::abs(V - out.end_V) >= kOnZero_V) return V;
    const double end = out.end_V;
    out.end_V = std::numeric_limits<double>::quiet_NaN();  // 0 V stops; else the ramp goes on
    return end;
  }
  return step_towards(out.V, 0.0, supervisor_.settings().ramp_down_V_per_s, dt);
}

void DriveLoop::update_sync(Output& out, double t) {
  const auto waveform_period = static_cast<long>(std::floor(t / settings_.period_s));
  const bool want_sync =
      out.phase == DrivePhase::driving && waveform_period != out.last_waveform_period;
  out.last_waveform_period = waveform_period;
  if (want_sync != out.sync_high) {
    count_failure(io_.lines.set_sync(want_sync));
    out.sync_high = want_sync;
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

StopCause DriveLoop::run(hal::TimeNs t0) {
  const auto period = hal::from_seconds(1.0 / settings_.rate_hz);
  const double dt = 1.0 / settings_.rate_hz;
  // Enable only once the drive holds 0 V and the e-stop has been looked at.
  if (!enable()) {
    stop_output(t0);
    return supervisor_.cause();
  }
  hal::TimeNs deadline = t0;
  Output out;
  for (;;) {
    io_.clock.sleep_until(deadline);
    const hal::TimeNs now = io_.clock.now();
    health_.period_error.record(now - deadline);
    // The value belongs to its deadline: a hardware-timed DAC latches it on
    // the grid, so wake-up jitter must not shift the waveform's phase.
    const double t = hal::to_seconds(deadline - t0);
    const SafetyAction action = check(now, t);
    if (action == SafetyAction::disable_now) {
      health_.count(health_.cycles);
      stop_output(deadline);  // instead of this deadline's value
      return supervisor_.cause();
    }
    if (action == SafetyAction::ramp_down && out.phase == DrivePhase::driving) {
      begin_ramp(out);
      // A waveform that completes on its own 0 V (a step's whole periods)
      // and is there within this update has nothing to ramp: it stops on
      // this deadline, and no record or state says ramping_down. Its
      // samples are the driven ones; the stop record follows them.
      if (out.end_V == 0.0 && std::abs(limit_voltage(settings_.limits, 0.0, out.V, dt)) == 0.0) {
        stop_output(deadline);
        return supervisor_.cause();
      }
    }
    health_.count(health_.cycles);
    out.V = next_value(out, t, dt);
    const hal::Status written = io_.drive.write(out.V);
    supervisor_.report_drive_write(written);
    update_sync(out, t);
    emit(deadline, out.V, out.phase, written);
    if (out.phase == DrivePhase::ramping_down && out.V == 0.0) {
      // The stop record belongs to the grid too: the next deadline.
      stop_output(deadline + period);
      return supervisor_.cause();
    }
    deadline += period;
    count_lateness(deadline, period);
  }
}

}  // namespace piezo::firmware
