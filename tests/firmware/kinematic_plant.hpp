#pragma once
// A rig reduced to stick-slip kinematics, for the drive programs' unit
// tests: the rotor follows the stator while the voltage changes slowly and
// stays where it is while it changes fast, seen by a noisy sensor.

#include <cmath>
#include <random>

namespace piezo::firmware {

constexpr double kDt = 1e-4;          // drive period [s]
constexpr int kTicksPerReading = 10;  // 1 kHz sensor
constexpr double kR2 = 0.062;         // sensor radius [m]
constexpr double kZero = 0.07;        // reading at the rotor's start [m]
constexpr double kSlipRate = 2000.0;  // |dV/dt| above this slips [V/s]

/// The rig a drive program drives, reduced to kinematics.
struct TestPlant {
  double stick_rad_per_V = 31.4e-6;  ///< the rotor's angle per stator volt while it sticks
  double noise_m = 0.5e-6;
  bool blocked = false;      ///< the rotor cannot turn at all: the sensor sees nothing swing
  bool never_slips = false;  ///< too much normal force: the rotor swings, no net step
  bool frozen = false;       ///< the sensor repeats its first reading
  double theta = 0.0;        ///< the rotor's true angle [rad]
  double V = 0.0;
  /// Where the rotor last rested at 0 V, and how it got there from the rest
  /// before (signed): the arrival a move ending at 0 V leaves.
  double rest = 0.0, arrival = 0.0;
  bool slipping = false;  ///< the last tick was part of a fast edge
  double last_dV = 0.0;
  std::mt19937 rng{7};
  std::normal_distribution<double> gauss{0.0, 1.0};
  double first_reading = std::nan("");

  void drive(double V_new) {
    const double dV = V_new - V;
    // A fast edge's last tick moves the stator less than a whole tick's
    // worth, yet just as fast: it slips too.
    const bool fast = std::abs(dV) / kDt > kSlipRate || (slipping && dV * last_dV > 0.0);
    slipping = fast;
    if (dV != 0.0) last_dV = dV;
    if (!blocked && (never_slips || !fast)) {
      theta += stick_rad_per_V * dV;
    }
    V = V_new;
    if (V == 0.0 && std::abs(theta - rest) > 1e-9) {
      arrival = theta - rest;
      rest = theta;
    }
  }
  double read() {
    const double d = kZero + kR2 * theta + noise_m * gauss(rng);
    if (std::isnan(first_reading)) first_reading = d;
    return frozen ? first_reading : d;
  }
};

}  // namespace piezo::firmware
