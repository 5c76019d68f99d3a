#include "piezo/hal/sim/sim_drive.hpp"

#include <algorithm>
#include <cmath>

namespace piezo::hal::sim {

SimDrive::SimDrive(const DacSettings& dac, Plant& plant, const Clock& clock)
    : dac_(dac), plant_(plant), clock_(clock), max_code_((1U << dac.bits) - 1U) {}

DriveLimits SimDrive::limits() const {
  const AmplifierSettings& amp = plant_.amplifier();
  return {std::max(0.0, amp.V_out_min), std::min(amp.gain * dac_.full_scale_V, amp.V_out_max)};
}

Status SimDrive::write(double volts) {
  const double V_dac = volts / plant_.amplifier().gain;
  if (!(V_dac >= 0.0 && V_dac <= dac_.full_scale_V * (1.0 + 1e-12))) return Status::out_of_range;
  const double code = std::round(V_dac / dac_.full_scale_V * max_code_);
  last_code_ = static_cast<unsigned>(std::min(code, static_cast<double>(max_code_)));
  plant_.set_input(clock_.now(), last_code_ * dac_.full_scale_V / max_code_);
  return Status::ok;
}

}  // namespace piezo::hal::sim
