#include "piezo/hal/sim/sim_drive.hpp"

#include <algorithm>
#include <cmath>

namespace piezo::hal::sim {

SimDrive::SimDrive(const DacSettings& dac, Plant& plant, Clock& clock, TimeNs tick_origin)
    : dac_(dac),
      plant_(plant),
      clock_(clock),
      max_code_((1U << dac.bits) - 1U),
      period_(from_seconds(dac.update_period_s)),
      tick_origin_(tick_origin) {}

TimeNs SimDrive::next_tick(TimeNs t) const {
  const TimeNs since = t - tick_origin_;
  const TimeNs k = since >= 0 ? since / period_ + 1 : -((-since) / period_);
  return tick_origin_ + k * period_;
}

DriveLimits SimDrive::limits() const {
  const AmplifierSettings& amp = plant_.amplifier();
  return {std::max(0.0, amp.V_out_min), std::min(amp.gain * dac_.full_scale_V, amp.V_out_max)};
}

Status SimDrive::write(double volts) {
  const double V_dac = volts / plant_.amplifier().gain;
  if (!(V_dac >= 0.0 && V_dac <= dac_.full_scale_V * (1.0 + 1e-12))) return Status::out_of_range;
  const double code = std::round(V_dac / dac_.full_scale_V * max_code_);
  last_code_ = static_cast<unsigned>(std::min(code, static_cast<double>(max_code_)));
  const double V_out = last_code_ * dac_.full_scale_V / max_code_;
  acknowledged_V_ = V_out * plant_.amplifier().gain;
  TimeNs now = clock_.now();
  if (!stalled_ && to_seconds(now - tick_origin_) >= dac_.stall_at_s) {
    stalled_ = true;
    clock_.sleep_until(now + from_seconds(dac_.stall_for_s));
    now = clock_.now();
  }
  if (period_ <= 0) {
    plant_.set_input(now, V_out);
    return Status::ok;
  }
  // Latch what the last tick took, then hold this code for the next tick;
  // a later write before that tick overwrites it, as in a DAC's register.
  if (pending_ && pending_tick_ <= now) plant_.set_input(pending_tick_, pending_V_);
  pending_ = true;
  pending_tick_ = next_tick(now);
  pending_V_ = V_out;
  return Status::ok;
}

}  // namespace piezo::hal::sim
