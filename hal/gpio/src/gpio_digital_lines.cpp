#include "piezo/hal/gpio/gpio_digital_lines.hpp"

#include <stdexcept>

namespace piezo::hal::gpio {

GpioDigitalLines::GpioDigitalLines(const GpioLinesSettings& settings, OutputLineGroup& outputs,
                                   InputLine* estop)
    : settings_(settings), outputs_(outputs), estop_(estop) {
  if (outputs.size() != (settings.has_sync ? 2u : 1u)) {
    throw std::invalid_argument("digital lines: expected enable and, if configured, sync");
  }
}

Status GpioDigitalLines::apply() {
  levels_[0] = enabled_ != settings_.enable_active_low ? 1 : 0;
  levels_[1] = sync_ != settings_.sync_active_low ? 1 : 0;
  return outputs_.set_levels(std::span<const int>(levels_.data(), outputs_.size()));
}

Status GpioDigitalLines::set_amplifier_enable(bool enabled) {
  enabled_ = enabled;
  return apply();
}

Status GpioDigitalLines::set_sync(bool high) {
  if (!settings_.has_sync) return Status::ok;
  sync_ = high;
  return apply();
}

EstopState GpioDigitalLines::poll_estop() {
  if (estop_ == nullptr) return {};
  EstopState state;
  int edges = 0, level = 0;
  state.status = estop_->take_edges(edges);
  if (state.status == Status::ok) state.status = estop_->level(level);
  state.edge_seen = edges > 0;
  state.pressed = (level == 0) == settings_.estop_active_low;
  return state;
}

}  // namespace piezo::hal::gpio
