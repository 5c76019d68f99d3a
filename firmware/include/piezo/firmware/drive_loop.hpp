#pragma once
/// @file
/// The drive loop: at every absolute deadline (default 10 kHz) it evaluates
/// each axis's program, applies that axis's safety decision and voltage
/// limits, writes every axis's drive on the same deadline, pulses sync at
/// each period start of the first axis and pushes one DriveSample per axis.
/// Everything is built before run(); the loop allocates nothing, takes no
/// locks, throws nothing and does no I/O beyond the HAL.
///
/// Safety has two layers. An axis's own cause (its sensor, its drive, its
/// program's fault, its travel window, its end) stops that axis: it ramps
/// to 0 V while the others go on, unless fault_stops_all, when its fault
/// ramps every other axis down too (cause other_axis_fault). A board cause
/// (the e-stop, the lease, an operator stop) reaches every axis's
/// supervisor at once. The amplifier enable is the board's: it drops when
/// the last axis stops, at an e-stop, and when an axis cannot confirm 0 V
/// (its drive no longer answers: only the enable still works).

#include <atomic>
#include <cstdint>
#include <limits>
#include <vector>

#include "piezo/firmware/drive_program.hpp"
#include "piezo/firmware/loop_health.hpp"
#include "piezo/firmware/output_state.hpp"
#include "piezo/firmware/safety_supervisor.hpp"
#include "piezo/firmware/samples.hpp"
#include "piezo/firmware/spsc_ring.hpp"
#include "piezo/firmware/voltage_limiter.hpp"
#include "piezo/hal/clock.hpp"
#include "piezo/hal/digital_lines.hpp"
#include "piezo/hal/drive.hpp"
#include "piezo/model/waveform.hpp"

namespace piezo::firmware {

/// The board's: one tick for every axis.
struct DriveLoopSettings {
  double rate_hz = 10'000.0;
  double duration_s = 4.8;
  /// An axis's own fault ramps every axis down, not only its own.
  bool fault_stops_all = false;
};

/// One axis the loop drives; everything it refers to outlives the loop.
struct DriveAxis {
  VoltageLimits limits;
  double period_s = 0.1;  ///< of its waveform (the first axis's paces the sync pulse)
  DriveProgram* program = nullptr;
  SafetySupervisor* supervisor = nullptr;
  hal::Drive* drive = nullptr;
  SpscRing<DriveSample>* ring = nullptr;
  std::uint8_t index = 0;  ///< the board's axis, written on its records
  /// An operator's stop of this axis alone (null: none): it ramps down as
  /// at a stop of the run, while the other axes go on.
  const std::atomic<bool>* stop_requested = nullptr;
  /// The same stop, at once: 0 V on the next deadline instead of a ramp.
  const std::atomic<bool>* stop_now_requested = nullptr;
};

/// The board's devices and channels; all outlive the loop.
struct DriveLoopIo {
  hal::Clock& clock;
  hal::DigitalLines& lines;
  const std::atomic<bool>& stop_requested;
  const std::atomic<bool>& stop_now_requested;  ///< every axis's stop, at once
};

/// How an axis's drive was left when it stopped: what the device
/// acknowledged, never what was only commanded.
struct OutputOutcome {
  bool enabled_ever = false;    ///< the amplifier was enabled at some point
  bool zero_confirmed = false;  ///< the drive acknowledged 0 V at the stop
  /// ...measured on an input wired to the output (hal::Drive::reads_back);
  /// false: 0 V is the device's acknowledgement of the write alone.
  bool zero_read_back = false;
  /// The last output the drive acknowledged [V] (NaN: none ever).
  double acknowledged_V = std::numeric_limits<double>::quiet_NaN();
  hal::Status enable_status = hal::Status::ok;  ///< of dropping the board's enable line
  hal::Status zero_status = hal::Status::ok;    ///< of the last 0 V write
  std::uint32_t zero_writes = 0;                ///< 0 V writes the stop took
};

[[nodiscard]] inline OutputState output_state(const OutputOutcome& o) {
  if (!o.zero_confirmed) return OutputState::output_unconfirmed;
  if (o.enable_status != hal::Status::ok) return OutputState::enable_unconfirmed;
  return OutputState::confirmed;
}

class DriveLoop {
 public:
  /// `axes` holds at least one axis.
  DriveLoop(const DriveLoopSettings& settings, std::vector<DriveAxis> axes, DriveLoopIo io);
  /// One axis.
  DriveLoop(const DriveLoopSettings& settings, const DriveAxis& axis, DriveLoopIo io)
      : DriveLoop(settings, std::vector<DriveAxis>{axis}, io) {}

  /// Runs from t0 (the run's time origin, a future time on the clock) until
  /// every axis has stopped; returns the run's cause (run_cause()) with the
  /// amplifier disabled. The amplifier is enabled only after every axis
  /// acknowledged 0 V and the e-stop was polled; the last stop drops the
  /// enable first, then writes 0 V until the drive acknowledges it or
  /// safety.stop_confirm_s passes (see outcome()).
  StopCause run(hal::TimeNs t0);

  /// Valid once run() has returned.
  [[nodiscard]] const OutputOutcome& outcome(std::size_t axis = 0) const {
    return axes_[axis].outcome;
  }
  [[nodiscard]] StopCause cause(std::size_t axis) const {
    return axes_[axis].io.supervisor->cause();
  }
  [[nodiscard]] std::size_t axis_count() const { return axes_.size(); }

  [[nodiscard]] LoopHealth& health() { return health_; }
  [[nodiscard]] const LoopHealth& health() const { return health_; }

 private:
  /// What the loop carries for an axis from one cycle to the next.
  struct Output {
    double V = 0.0;
    DrivePhase phase = DrivePhase::driving;
    /// The value a completed waveform ends on, approached at the slew limit
    /// (NaN: none, or reached).
    double end_V = std::numeric_limits<double>::quiet_NaN();
  };
  struct Axis {
    DriveAxis io;
    Output out;
    OutputOutcome outcome;
    bool stopped = false;
    int stop_rank = 0;  ///< 1 for the first axis to stop, and so on
  };

  /// 0 V written on every axis and the e-stop looked at, then the amplifier
  /// enabled; false when the supervisors stop the run before that.
  bool enable();
  /// Every axis has written the tick's value: drives that take all axes'
  /// values at once send them; a failure counts as each axis's failed write
  /// (at the start: a drive that does not take 0 V).
  void end_tick(bool starting);
  /// Tells each axis's program whether another axis is stepping at t (crosstalk).
  void tell_neighbours_stepping(double t);
  /// An axis's supervisor's verdict for the cycle at t [s from the time origin].
  SafetyAction check(Axis& axis, hal::TimeNs now, double t, const hal::EstopState& estop);
  /// One axis's cycle; false when it only stopped on its own end (a
  /// waveform completing on 0 V: no cycle of the drive's).
  bool drive_axis(Axis& axis, hal::TimeNs deadline, hal::TimeNs now, double t, double dt,
                  const hal::EstopState& estop);
  void begin_ramp(Axis& axis);
  /// The next value: the program's, a completed waveform's end, or the ramp.
  [[nodiscard]] double next_value(Axis& axis, double t, double dt);
  /// An axis's fault ramps the others down when the board says so.
  void spread_faults();
  /// Sync: high for the first drive cycle of each of the first axis's periods.
  void update_sync(double t);
  void count_lateness(hal::TimeNs deadline, hal::TimeNs period);
  void emit(Axis& axis, hal::TimeNs t, double V, DrivePhase phase, hal::Status status);
  /// Stops one axis at t: 0 V until acknowledged; the enable drops first when
  /// it is the last axis running. An axis that cannot confirm 0 V stops the
  /// board (only the enable still works on it).
  void stop_axis(Axis& axis, hal::TimeNs t);
  /// Every axis still running stops now, the enable first.
  void stop_all(hal::TimeNs t);
  void drop_enable();
  void count_failure(hal::Status s);
  [[nodiscard]] bool all_stopped() const;
  [[nodiscard]] StopCause run_cause() const;

  DriveLoopSettings settings_;
  std::vector<Axis> axes_;
  DriveLoopIo io_;
  LoopHealth health_;
  int stops_ = 0;
  bool enable_dropped_ = false;
  hal::Status enable_status_ = hal::Status::ok;
  long last_sync_period_ = -1;
  bool sync_high_ = false;
};

}  // namespace piezo::firmware
