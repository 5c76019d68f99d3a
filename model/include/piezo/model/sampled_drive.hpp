#pragma once
/// @file
/// A logged drive as an excitation: after each commanded sample the output
/// moves in a straight line from the previous value to the new one over
/// `ramp_time` and then holds, as the signal chain smooths the DAC's steps
/// (the simulated amplifier does exactly this). Lets the model replay any
/// logged run, whatever its waveform and however late its writes came.
/// Consecutive pieces that lie on one line (slopes equal to 1e-9, as a
/// sampled ramp's are up to rounding) are one piece: an integrator then
/// meets only the drive's real corners.

#include <span>
#include <vector>

#include "piezo/model/waveform.hpp"

namespace piezo::model {

class SampledDrive final : public Excitation {
 public:
  /// @param t sample times [s], strictly increasing; @param V voltages [V];
  /// @param ramp_time [s], > 0. Before the first sample the voltage is 0.
  SampledDrive(std::span<const double> t, std::span<const double> V, double ramp_time);

  [[nodiscard]] double voltage(double t) const override { return piece(t).at(t); }
  [[nodiscard]] double next_breakpoint(double t) const override;
  [[nodiscard]] LinearPiece piece(double t) const override;
  [[nodiscard]] PieceSpan span(double t) const override;

 private:
  /// The pieces, merged where collinear: piece k holds from start_[k] on.
  std::vector<double> start_;
  std::vector<LinearPiece> pieces_;
};

}  // namespace piezo::model
