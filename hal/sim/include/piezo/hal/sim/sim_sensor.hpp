#pragma once
/// @file
/// The simulated laser displacement sensor: it reads the plant's rotor at
/// the reflector radius r2 and adds what real sensors add — offset, noise,
/// quantisation, latency, dropouts, and a stall (no answer) for fault tests.

#include <limits>
#include <random>

#include "piezo/hal/backend.hpp"
#include "piezo/hal/displacement_sensor.hpp"
#include "piezo/hal/sim/plant.hpp"

namespace piezo::hal::sim {

struct SimSensorSettings {
  double rate_hz = 1000.0;
  double r2_m = kDefaultSensorRadius_m;  ///< reflector radius: d = offset + r2 * theta
  double offset_m = 0.07;                ///< reading at theta = 0 (mid-range)
  double noise_m = 0.5e-6;               ///< standard deviation of white noise
  double quantum_m = 0.1e-6;             ///< resolution of the reported value (0: none)
  double latency_s = 200e-6;             ///< from request to answer
  double dropout_probability = 0.0;      ///< answers flagged invalid
  double timeout_s = 0.05;               ///< a stalled read gives up after this
  double stall_at_s = std::numeric_limits<double>::infinity();  ///< stops answering from here
  double stall_for_s = std::numeric_limits<double>::infinity();
  /// From here every reading repeats the one before (a sensor whose value
  /// froze while it keeps answering).
  double freeze_at_s = std::numeric_limits<double>::infinity();
  /// From here the sensor sees a rotor that is not driven: the angle it had
  /// then, with the noise (a laser spot off the reflector, another rig's).
  double blind_at_s = std::numeric_limits<double>::infinity();
  unsigned seed = 1;
};

class SimSensor final : public DisplacementSensor {
 public:
  /// Times in the settings count from `t0`.
  SimSensor(const SimSensorSettings& settings, const Plant& plant, Clock& clock, TimeNs t0);

  [[nodiscard]] DisplacementReading read() override;

  /// Moves the time origin of the settings' times, before the run starts.
  /// A run's time origin: its faults count from here, and its noise starts
  /// again from the seed, so a run on the virtual clock repeats exactly
  /// whatever was read before it (the board reads its sensors at rest).
  void set_time_origin(TimeNs t0);

 private:
  [[nodiscard]] bool stalled(TimeNs t) const;

  SimSensorSettings settings_;
  const Plant& plant_;
  Clock& clock_;
  TimeNs t0_;
  std::mt19937_64 random_;
  std::normal_distribution<double> noise_;
  std::uniform_real_distribution<double> uniform_{0.0, 1.0};
  double frozen_m_ = std::numeric_limits<double>::quiet_NaN();
  double blind_theta_ = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace piezo::hal::sim
