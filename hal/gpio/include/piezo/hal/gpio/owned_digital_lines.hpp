#pragma once
/// @file
/// The rig's digital lines together with the device lines they drive and
/// read: a device's outputs (enable, sync, triggers) and e-stop input, built first and
/// owned here, under the one logic of GpioDigitalLines that every call goes
/// to. libgpiod's lines and a DAQ card's digital I/O both come this way.

#include <memory>
#include <utility>

#include "piezo/hal/gpio/gpio_digital_lines.hpp"

namespace piezo::hal::gpio {

class OwnedDigitalLines final : public DigitalLines {
 public:
  /// `outputs`: enable, then sync if configured, at idle_levels(); `estop`
  /// may be null (not wired).
  OwnedDigitalLines(const GpioLinesSettings& settings, std::unique_ptr<OutputLineGroup> outputs,
                    std::unique_ptr<InputLine> estop, GpioTriggerLines triggers = {})
      : outputs_(std::move(outputs)),
        estop_(std::move(estop)),
        lines_(settings, *outputs_, estop_.get(), std::move(triggers)) {}

  Status set_amplifier_enable(bool enabled) override {
    return lines_.set_amplifier_enable(enabled);
  }
  Status set_sync(bool high) override { return lines_.set_sync(high); }
  [[nodiscard]] EstopState poll_estop() override { return lines_.poll_estop(); }
  bool trip() override { return lines_.trip(); }
  [[nodiscard]] bool reset_estop() override { return lines_.reset_estop(); }
  [[nodiscard]] bool has_trigger(std::size_t axis) const override {
    return lines_.has_trigger(axis);
  }
  Status set_trigger(std::size_t axis, bool high) override {
    return lines_.set_trigger(axis, high);
  }

 private:
  std::unique_ptr<OutputLineGroup> outputs_;
  std::unique_ptr<InputLine> estop_;
  GpioDigitalLines lines_;  ///< last: stopped (its watcher joined) before the lines go
};

}  // namespace piezo::hal::gpio
