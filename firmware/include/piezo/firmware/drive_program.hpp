#pragma once
/// @file
/// What the drive loop follows: a voltage per drive cycle. A fixed waveform
/// (the sawtooth of a timed run or a step) or a controller that decides from
/// the measured angle (a closed-loop move). Called from the drive loop only:
/// an implementation allocates nothing, takes no locks and throws nothing.

#include <cstdint>
#include <limits>

#include "piezo/firmware/safety_supervisor.hpp"
#include "piezo/model/waveform.hpp"

namespace piezo::firmware {

class DriveProgram {
 public:
  virtual ~DriveProgram() = default;
  /// The voltage wanted at t [s from the time origin]; dt is the drive period.
  virtual double next_voltage(double t, double dt) = 0;
  /// True once the program has nothing more to drive: the run ends as completed.
  [[nodiscard]] virtual bool finished() const { return false; }
  /// The voltage to end on at the run's duration, when the program is a
  /// fixed waveform (a step of whole periods ends on its period's 0 V, with
  /// nothing to ramp); NaN for a program that decides as it goes.
  [[nodiscard]] virtual double end_voltage(double /*duration_s*/) const {
    return std::numeric_limits<double>::quiet_NaN();
  }
  /// Why the program wants the run stopped (none: it does not): a
  /// controller that finds its plant or its sensor not as it must be.
  [[nodiscard]] virtual StopCause fault() const { return StopCause::none; }
  /// A code for the drive record (0: no controller; see MoveState).
  [[nodiscard]] virtual std::uint8_t state_code() const { return 0; }
  /// True while its output steps the rotor (stick-slip): on a frame shared
  /// with other axes, each slip shakes them (crosstalk).
  [[nodiscard]] virtual bool stepping() const { return false; }
  /// Told every drive tick, before next_voltage, whether another axis of
  /// the run is stepping at t [s]: a controller holding its rotor may mask
  /// the shake instead of correcting it.
  virtual void set_neighbours_stepping(bool /*stepping*/, double /*t*/) {}
};

/// A fixed waveform as a program.
class WaveformProgram final : public DriveProgram {
 public:
  explicit WaveformProgram(const model::Excitation& waveform) : waveform_(waveform) {}
  double next_voltage(double t, double) override { return waveform_.voltage(t); }
  [[nodiscard]] bool stepping() const override { return true; }  // the sawtooth steps throughout
  [[nodiscard]] double end_voltage(double duration_s) const override {
    return waveform_.voltage(duration_s);
  }

 private:
  const model::Excitation& waveform_;
};

}  // namespace piezo::firmware
