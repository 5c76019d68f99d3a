#pragma once
/// @file
/// A move's step table from the model: what one sawtooth period moves the
/// rotor at each of MoveSettings::kStepFractions of V0, both ways, at the
/// move's frequency and (uncalibrated) at twice and four times it. Each is
/// a simulation of one period, a few milliseconds in all; the tables are
/// kept per waveform, so the board's network thread computes a waveform's
/// once (the board's own [drive] at start-up, before any client calls),
/// and a move asks for a table it already has.

#include <array>
#include <map>
#include <tuple>

#include "piezo/firmware/move_controller.hpp"
#include "piezo/model/parameters.hpp"

namespace piezo::firmware {

/// Predicted step magnitudes [rad] at each of MoveSettings::kStepFractions.
struct StepTable {
  std::array<double, MoveSettings::kStepFractions.size()> forward_rad{}, reverse_rad{};
};

class MovePlanner {
 public:
  explicit MovePlanner(const model::MotorParameters& motor) : motor_(motor) {}

  /// One period from rest at each amplitude, each way (rise fraction D
  /// forward, 1 - D in reverse), at most 1e-3 of the stick stroke below:
  /// a prediction of (almost) nothing still gets a try, and the measured
  /// steps correct it.
  const StepTable& steps(double V0, double f, double D);

  /// Fills the move's model view: the stick stroke per volt, its step
  /// table at (V0, f, D), and with `alternatives` the tables at 2f and 4f
  /// as far as the drive's rate (f <= rate/20) and slew limit allow.
  void plan(MoveSettings& m, bool alternatives, double rate_hz, double slew_V_per_s);

 private:
  model::MotorParameters motor_;
  std::map<std::tuple<double, double, double>, StepTable> tables_;
};

}  // namespace piezo::firmware
