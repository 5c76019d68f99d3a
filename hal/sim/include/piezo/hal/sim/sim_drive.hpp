#pragma once
/// @file
/// The simulated drive chain: a unipolar DAC (resolution, full scale) whose
/// held output feeds the plant's amplifier. The DAC is hardware-timed: a
/// written code is latched on the DAC's next update tick (a timer driving
/// its LDAC input), so the software's wake-up jitter never reaches the
/// output; a write later than a whole period misses its tick.

#include <limits>

#include "piezo/hal/clock.hpp"
#include "piezo/hal/drive.hpp"
#include "piezo/hal/sim/plant.hpp"

namespace piezo::hal::sim {

struct DacSettings {
  int bits = 20;
  double full_scale_V = 5.0;     ///< output at the highest code
  double update_period_s = 0.0;  ///< latch ticks; 0 latches every write at once
  /// Fault injection, as a slow bus does it: the first write at or after
  /// stall_at_s [s from t0] blocks for stall_for_s.
  double stall_at_s = std::numeric_limits<double>::infinity();
  double stall_for_s = 0.0;
};

class SimDrive final : public Drive {
 public:
  /// Latch ticks fall at tick_origin + k * update_period.
  SimDrive(const DacSettings& dac, Plant& plant, Clock& clock, TimeNs tick_origin = 0);

  Status write(double volts) override;
  /// The value of the code the DAC took last (it takes every valid write).
  [[nodiscard]] double acknowledged_V() const override { return acknowledged_V_; }
  [[nodiscard]] DriveLimits limits() const override;
  /// A write in the drive loop's cycle latches on the next tick: one period.
  [[nodiscard]] double output_latency_s() const override { return dac_.update_period_s; }

  /// The DAC code the last write produced.
  [[nodiscard]] unsigned last_code() const { return last_code_; }
  /// A run's time origin, before the run starts: the DAC's ticks and the injected stall count from
  /// here (the stall is armed again: each run meets it, whatever the board
  /// wrote at rest before).
  void set_time_origin(TimeNs t0) {
    tick_origin_ = t0;
    stalled_ = false;
  }

 private:
  DacSettings dac_;
  Plant& plant_;
  Clock& clock_;  ///< not const: an injected stall sleeps on it
  [[nodiscard]] TimeNs next_tick(TimeNs t) const;
  bool stalled_ = false;  ///< the injected stall has been served

  unsigned max_code_;
  unsigned last_code_ = 0;
  TimeNs period_;
  TimeNs tick_origin_;
  // The code written but not yet latched (a DAC's input register).
  bool pending_ = false;
  TimeNs pending_tick_ = 0;
  double pending_V_ = 0.0;
  double acknowledged_V_ = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace piezo::hal::sim
