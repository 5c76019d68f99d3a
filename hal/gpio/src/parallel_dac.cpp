#include "piezo/hal/gpio/parallel_dac.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace piezo::hal::gpio {

ParallelDac::ParallelDac(const ParallelDacSettings& settings, OutputLineGroup& lines)
    : settings_(settings),
      lines_(lines),
      max_code_(settings.bits >= 32 ? 0xFFFFFFFFu : (1u << settings.bits) - 1u) {
  const std::size_t expected =
      static_cast<std::size_t>(settings.bits) + (settings.has_strobe ? 1 : 0);
  if (settings.bits < 1 || settings.bits > 32 || lines.size() != expected) {
    throw std::invalid_argument("parallel DAC: " + std::to_string(lines.size()) + " lines given, " +
                                std::to_string(expected) + " needed");
  }
}

std::vector<int> ParallelDac::idle_levels(const ParallelDacSettings& s) {
  std::vector<int> levels(static_cast<std::size_t>(s.bits), s.data_active_low ? 1 : 0);
  if (s.has_strobe) levels.push_back(s.strobe_active_low ? 1 : 0);
  return levels;
}

DriveLimits ParallelDac::limits() const {
  return {0.0, settings_.full_scale_V * settings_.amplifier_gain};
}

std::uint32_t ParallelDac::code_for(double volts) const {
  const double fraction = volts / settings_.amplifier_gain / settings_.full_scale_V;
  const double code = std::round(std::clamp(fraction, 0.0, 1.0) * static_cast<double>(max_code_));
  return static_cast<std::uint32_t>(code);
}

Status ParallelDac::put(std::uint32_t code, bool strobe_asserted) {
  const auto n = static_cast<std::size_t>(settings_.bits);
  for (std::size_t bit = 0; bit < n; ++bit) {
    const int logical = static_cast<int>((code >> bit) & 1u);
    levels_[bit] = settings_.data_active_low ? 1 - logical : logical;
  }
  if (settings_.has_strobe) {
    levels_[n] = strobe_asserted != settings_.strobe_active_low ? 1 : 0;
  }
  return lines_.set_levels(std::span<const int>(levels_.data(), lines_.size()));
}

Status ParallelDac::write(double volts) {
  const double fraction = volts / settings_.amplifier_gain / settings_.full_scale_V;
  if (!(fraction >= 0.0 && fraction <= 1.0 + 1e-12)) return Status::out_of_range;
  const std::uint32_t code = code_for(volts);
  // Data settle with the strobe idle, then the strobe pulses: the DAC
  // latches on the pulse's trailing edge, with every bit already stable.
  Status s = put(code, false);
  if (s == Status::ok && settings_.has_strobe) {
    s = put(code, true);
    if (s == Status::ok) s = put(code, false);
  }
  if (s == Status::ok) {
    acknowledged_V_ = static_cast<double>(code) / static_cast<double>(max_code_) *
                      settings_.full_scale_V * settings_.amplifier_gain;
  }
  return s;
}

}  // namespace piezo::hal::gpio
