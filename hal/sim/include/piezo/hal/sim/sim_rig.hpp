#pragma once
/// @file
/// The whole simulated rig: one plant (the motor behind its amplifier) with
/// the DAC that drives it, the sensor that watches it and the lines that
/// enable it. The three share the plant, so they are built together here.

#include <limits>

#include "piezo/hal/clock.hpp"
#include "piezo/hal/sim/plant.hpp"
#include "piezo/hal/sim/sim_drive.hpp"
#include "piezo/hal/sim/sim_lines.hpp"
#include "piezo/hal/sim/sim_sensor.hpp"
#include "piezo/model/parameters.hpp"

namespace piezo::hal::sim {

struct SimRigSettings {
  model::MotorParameters plant;
  AmplifierSettings amplifier;
  DacSettings dac;
  SimSensorSettings sensor;
  SimLinesSettings lines;
  /// An end stop the rotor cannot pass, at this angle from where it starts
  /// (NaN: none); for tests of a blocked rotor.
  double end_stop_rad = std::numeric_limits<double>::quiet_NaN();
};

class SimRig {
 public:
  /// Builds the rig on `clock` (which outlives it) with time origin `t0`.
  SimRig(const SimRigSettings& settings, Clock& clock, TimeNs t0);
  SimRig(const SimRig&) = delete;
  SimRig& operator=(const SimRig&) = delete;

  [[nodiscard]] SimDrive& drive() { return drive_; }
  [[nodiscard]] SimSensor& sensor() { return sensor_; }
  [[nodiscard]] SimLines& lines() { return lines_; }
  /// The device side, for checks: what the amplifier really outputs.
  [[nodiscard]] const Plant& plant() const { return plant_; }

  /// Moves the time origin of the DAC ticks, the sensor's faults and the
  /// e-stop schedule, before the run starts.
  void set_time_origin(TimeNs t0);

 private:
  Plant plant_;
  SimDrive drive_;
  SimSensor sensor_;
  SimLines lines_;
};

}  // namespace piezo::hal::sim
