#pragma once
/// @file
/// A logged drive as an excitation: straight lines between the commanded
/// samples, as the signal chain's reconstruction smooths the DAC's steps.
/// Lets the model replay any logged run, whatever its waveform.

#include <span>
#include <vector>

#include "piezo/model/waveform.hpp"

namespace piezo::model {

class SampledDrive final : public Excitation {
 public:
  /// @param t sample times [s], strictly increasing; @param V voltages [V].
  /// Before the first sample the voltage is 0; after the last it holds.
  SampledDrive(std::span<const double> t, std::span<const double> V);

  [[nodiscard]] double voltage(double t) const override { return piece(t).at(t); }
  [[nodiscard]] double next_breakpoint(double t) const override;
  [[nodiscard]] LinearPiece piece(double t) const override;

 private:
  std::vector<double> t_, V_;
};

}  // namespace piezo::model
