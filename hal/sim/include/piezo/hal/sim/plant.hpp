#pragma once
/// @file
/// The simulated rig's mechanics: the amplifier (gain, output limits, slew)
/// driving the LuGre motor. The drive thread advances it at every write; the
/// sensor thread reads the latest published angle without blocking (seqlock).

#include <atomic>
#include <cstdint>
#include <limits>
#include <vector>

#include "piezo/hal/clock.hpp"
#include "piezo/model/lugre_integrator.hpp"
#include "piezo/model/parameters.hpp"

namespace piezo::hal::sim {

struct AmplifierSettings {
  double gain = 20.0;            ///< output volts per input volt
  double V_out_min = 0.0;        ///< output rails [V]
  double V_out_max = 100.0;      ///< output rails [V]
  double slew_V_per_s = 50'000;  ///< output slew-rate limit
  /// Reconstruction of the DAC's steps: each new input is approached
  /// linearly over this time (one DAC update period interpolates the
  /// samples, a first-order hold); 0 passes the steps through. Steps at
  /// 10 kHz would ring the stator's 5.7 kHz mode, which a real signal chain
  /// filters out.
  double ramp_time_s = 100e-6;
};

/// What the sensor sees of the plant.
struct PlantSnapshot {
  TimeNs t = 0;
  double theta = 0.0;      ///< rotor angle [rad]
  double theta_dot = 0.0;  ///< rotor velocity [rad/s]
  double V_out = 0.0;      ///< amplifier output [V]
};

class Plant {
 public:
  /// `end_stop_rad`: the rotor stops dead at this angle (NaN: no stop).
  Plant(const model::MotorParameters& motor, const AmplifierSettings& amplifier, TimeNs t0,
        double end_stop_rad = std::numeric_limits<double>::quiet_NaN());

  /// Sets the amplifier's input [V] from time t on; the motor is first
  /// advanced to t under the previous input. Single writer (the drive thread).
  void set_input(TimeNs t, double V_in);
  /// Enables or disables the amplifier output (disabled: it slews to 0 V).
  void set_enabled(TimeNs t, bool enabled);
  /// Disables the amplifier from time t on, from any thread (the enable
  /// line dropped while the drive thread may be blocked): the output is
  /// seen disabled at once, and the motor follows from t when the drive
  /// thread next advances it.
  void trip(TimeNs t);
  /// Carries the motor to time t under the input it holds (no new input).
  /// Same writer as set_input.
  void advance(TimeNs t);
  /// A hand (or a knock) turns the rotor by `delta_rad` at time t, the
  /// stator left as it is: what the sensor sees of a rotor moved at rest.
  /// Same writer as set_input.
  void turn_by(TimeNs t, double delta_rad);
  /// Crosstalk: this plant's amplifier output also reaches `neighbour`'s
  /// stator, scaled by `coupling` (the share of this axis's stator stroke
  /// the neighbour's stator takes through the frame they share). Set up
  /// before the plants run; both written from the same drive thread.
  void couple_to(Plant& neighbour, double coupling);
  /// The latest published state. Any thread, wait-free for the writer.
  [[nodiscard]] PlantSnapshot latest() const;

  [[nodiscard]] const AmplifierSettings& amplifier() const { return amplifier_; }
  /// Whether the amplifier's output is enabled (any thread).
  [[nodiscard]] bool enabled() const { return published_enabled_.load(); }

 private:
  void advance_to(TimeNs t);
  /// Applies a trip() that came from another thread, at its own time.
  void take_trip();
  /// True when the motor is at rest under the held output (an idle gap can be skipped).
  [[nodiscard]] bool at_rest() const;
  void start_ramp();
  /// A rotor at or past the end stop is held there, at rest.
  void hold_at_end_stop();
  void publish();
  [[nodiscard]] double output_target() const;
  /// The stator's input: its own output and what its neighbours couple in.
  [[nodiscard]] double stator_V() const { return V_out_ + coupled_V_; }
  /// A source's output changed at t: the coupled input follows from t on.
  void update_coupled(TimeNs t);
  void notify_neighbours();

  struct Coupling {
    const Plant* source;
    double coupling;
  };

  AmplifierSettings amplifier_;
  model::LuGreIntegrator motor_;
  model::LuGreMotor rhs_;  ///< the same motor's equations, for the at-rest check
  TimeNs t_;
  double end_stop_rad_;
  double V_in_ = 0.0;
  double V_out_ = 0.0;
  double slope_ = 0.0;   // of the output's ramp towards its target [V/s]
  TimeNs ramp_end_ = 0;  // when the target is reached
  bool enabled_ = false;
  double coupled_V_ = 0.0;          ///< the neighbours' outputs, as this stator sees them
  std::vector<Coupling> sources_;   ///< whose outputs reach this stator
  std::vector<Plant*> neighbours_;  ///< whose stators this output reaches

  std::atomic<std::uint64_t> sequence_{0};
  std::atomic<TimeNs> published_t_{0};
  std::atomic<double> published_theta_{0.0};
  std::atomic<double> published_theta_dot_{0.0};
  std::atomic<double> published_V_out_{0.0};
  std::atomic<bool> published_enabled_{false};
  static constexpr TimeNs kNoTrip = std::numeric_limits<TimeNs>::max();
  std::atomic<TimeNs> trip_at_{kNoTrip};
};

}  // namespace piezo::hal::sim
