#pragma once
/// @file
/// The simulated drive chain: a unipolar DAC (resolution, full scale) whose
/// held output feeds the plant's amplifier.

#include "piezo/hal/clock.hpp"
#include "piezo/hal/drive.hpp"
#include "piezo/hal/sim/plant.hpp"

namespace piezo::hal::sim {

struct DacSettings {
  int bits = 20;
  double full_scale_V = 5.0;  ///< output at the highest code
};

class SimDrive final : public Drive {
 public:
  SimDrive(const DacSettings& dac, Plant& plant, const Clock& clock);

  Status write(double volts) override;
  [[nodiscard]] DriveLimits limits() const override;

  /// The DAC code the last write produced.
  [[nodiscard]] unsigned last_code() const { return last_code_; }

 private:
  DacSettings dac_;
  Plant& plant_;
  const Clock& clock_;
  unsigned max_code_;
  unsigned last_code_ = 0;
};

}  // namespace piezo::hal::sim
