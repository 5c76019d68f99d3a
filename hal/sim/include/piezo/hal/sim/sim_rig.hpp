#pragma once
/// @file
/// The whole simulated rig: one plant per axis (a motor behind its
/// amplifier) with the DAC that drives it and the sensor that watches it,
/// and the board's lines, whose one enable reaches every axis's amplifier.
/// The parts of an axis share its plant, so they are built together here.

#include <cstddef>
#include <limits>
#include <memory>
#include <vector>

#include "piezo/hal/clock.hpp"
#include "piezo/hal/sim/plant.hpp"
#include "piezo/hal/sim/sim_drive.hpp"
#include "piezo/hal/sim/sim_lines.hpp"
#include "piezo/hal/sim/sim_sensor.hpp"
#include "piezo/model/parameters.hpp"

namespace piezo::hal::sim {

/// One axis: its motor, amplifier, DAC and sensor.
struct SimAxisSettings {
  model::MotorParameters plant;
  AmplifierSettings amplifier;
  DacSettings dac;
  SimSensorSettings sensor;
  /// An end stop the rotor cannot pass, at this angle from where it starts
  /// (NaN: none); for tests of a blocked rotor.
  double end_stop_rad = std::numeric_limits<double>::quiet_NaN();
  /// Crosstalk: the share of every other axis's stator stroke this axis's
  /// stator takes through the frame they share (0: none). A neighbour's
  /// sawtooth rocks this stator, and its fast edge can slip this rotor.
  double coupling = 0.0;
};

/// A rig of one axis.
struct SimRigSettings : SimAxisSettings {
  SimLinesSettings lines;
};

class SimRig {
 public:
  /// Builds the rig on `clock` (which outlives it) with time origin `t0`.
  SimRig(const SimRigSettings& settings, Clock& clock, TimeNs t0)
      : SimRig(std::vector<SimAxisSettings>{settings}, settings.lines, clock, t0) {}
  /// Several axes (at least one) on one board's lines.
  SimRig(const std::vector<SimAxisSettings>& axes, const SimLinesSettings& lines, Clock& clock,
         TimeNs t0);
  SimRig(const SimRig&) = delete;
  SimRig& operator=(const SimRig&) = delete;

  [[nodiscard]] std::size_t axis_count() const { return axes_.size(); }
  [[nodiscard]] SimDrive& drive(std::size_t axis = 0) { return axes_[axis]->drive; }
  [[nodiscard]] SimSensor& sensor(std::size_t axis = 0) { return axes_[axis]->sensor; }
  [[nodiscard]] SimLines& lines() { return *lines_; }
  /// The device side, for checks: what the amplifier really outputs.
  [[nodiscard]] const Plant& plant(std::size_t axis = 0) const { return axes_[axis]->plant; }

  /// Moves the time origin of the DAC ticks, the sensors' faults and the
  /// e-stop schedule, before the run starts.
  void set_time_origin(TimeNs t0);
  /// Carries every plant to time t under the input it holds: between runs,
  /// when no drive writes, what the rotors did meanwhile (settled, turned)
  /// is what the sensors then read. From the thread that holds the rig.
  void advance_to(TimeNs t);

 private:
  struct Axis {
    Axis(const SimAxisSettings& s, Clock& clock, TimeNs t0)
        : plant(s.plant, s.amplifier, t0, s.end_stop_rad),
          drive(s.dac, plant, clock, t0),
          sensor(s.sensor, plant, clock, t0) {}
    Plant plant;
    SimDrive drive;
    SimSensor sensor;
  };
  std::vector<std::unique_ptr<Axis>> axes_;
  std::unique_ptr<SimLines> lines_;
};

}  // namespace piezo::hal::sim
