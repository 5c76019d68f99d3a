#pragma once
/// @file
/// The drive loop: at every absolute deadline (default 10 kHz) it evaluates
/// the waveform, applies the safety decision and the voltage limits, writes
/// the drive, pulses sync at each period start and pushes a DriveSample.
/// Everything is built before run(); the loop allocates nothing, takes no
/// locks, throws nothing and does no I/O beyond the HAL.

#include <atomic>
#include <cstdint>
#include <limits>

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

struct DriveLoopSettings {
  double rate_hz = 10'000.0;
  double duration_s = 4.8;
  double period_s = 0.1;  ///< of the waveform, for the sync pulse
  VoltageLimits limits;
};

/// The devices and channels one drive loop works with; all outlive the loop.
struct DriveLoopIo {
  hal::Clock& clock;
  hal::Drive& drive;
  hal::DigitalLines& lines;
  SpscRing<DriveSample>& ring;
  const std::atomic<bool>& stop_requested;
};

/// How the drive was left when the loop returned: what the device
/// acknowledged, never what was only commanded.
struct OutputOutcome {
  bool enabled_ever = false;    ///< the amplifier was enabled at some point
  bool zero_confirmed = false;  ///< the drive acknowledged 0 V at the stop
  /// ...measured on an input wired to the output (hal::Drive::reads_back);
  /// false: 0 V is the device's acknowledgement of the write alone.
  bool zero_read_back = false;
  /// The last output the drive acknowledged [V] (NaN: none ever).
  double acknowledged_V = std::numeric_limits<double>::quiet_NaN();
  hal::Status enable_status = hal::Status::ok;  ///< of dropping the enable line
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
  /// `program` (a waveform or a move) outlives the loop.
  DriveLoop(const DriveLoopSettings& settings, DriveProgram& program, SafetySupervisor& supervisor,
            DriveLoopIo io);

  /// Runs from t0 (the run's time origin, a future time on the clock) until
  /// the supervisor stops it; returns with the amplifier disabled. The
  /// amplifier is enabled only after 0 V is acknowledged and the e-stop
  /// polled; the stop drops the enable first, then writes 0 V until the
  /// drive acknowledges it or safety.stop_confirm_s passes (see outcome()).
  StopCause run(hal::TimeNs t0);

  /// Valid once run() has returned.
  [[nodiscard]] const OutputOutcome& outcome() const { return outcome_; }

  [[nodiscard]] LoopHealth& health() { return health_; }
  [[nodiscard]] const LoopHealth& health() const { return health_; }

 private:
  /// What the loop carries from one cycle to the next.
  struct Output {
    double V = 0.0;
    DrivePhase phase = DrivePhase::driving;
    /// The value a completed waveform ends on, approached at the slew limit
    /// (NaN: none, or reached).
    double end_V = std::numeric_limits<double>::quiet_NaN();
    long last_waveform_period = -1;
    bool sync_high = false;
  };

  /// 0 V written and the e-stop looked at, then the amplifier enabled; false
  /// when the supervisor stops the run before that.
  bool enable();
  /// The supervisor's verdict for the cycle at t [s from the time origin].
  SafetyAction check(hal::TimeNs now, double t);
  void begin_ramp(Output& out);
  /// The next value: the program's, a completed waveform's end, or the ramp.
  [[nodiscard]] double next_value(Output& out, double t, double dt);
  /// Sync: high for the first drive cycle of each waveform period.
  void update_sync(Output& out, double t);
  void count_lateness(hal::TimeNs deadline, hal::TimeNs period);
  void emit(hal::TimeNs t, double V, DrivePhase phase, hal::Status status);
  void stop_output(hal::TimeNs t);
  void count_failure(hal::Status s);

  DriveLoopSettings settings_;
  DriveProgram& program_;
  SafetySupervisor& supervisor_;
  DriveLoopIo io_;
  LoopHealth health_;
  OutputOutcome outcome_;
};

}  // namespace piezo::firmware
