#pragma once
/// @file
/// The rig's digital lines on GPIO: amplifier enable and sync as one output
/// group, e-stop as an input with edge events, each line's polarity from
/// config.

#include <array>

#include "piezo/hal/digital_lines.hpp"
#include "piezo/hal/line_group.hpp"

namespace piezo::hal::gpio {

struct GpioLinesSettings {
  bool has_sync = true;
  bool enable_active_low = false;
  bool sync_active_low = false;
  bool estop_active_low = true;  ///< a normally-closed e-stop pulled up: pressed = low
};

class GpioDigitalLines final : public DigitalLines {
 public:
  /// `outputs`: enable, then sync if any. `estop` may be null (no e-stop wired).
  GpioDigitalLines(const GpioLinesSettings& settings, OutputLineGroup& outputs, InputLine* estop);

  Status set_amplifier_enable(bool enabled) override;
  Status set_sync(bool high) override;
  [[nodiscard]] EstopState poll_estop() override;

 private:
  Status apply();

  GpioLinesSettings settings_;
  OutputLineGroup& outputs_;
  InputLine* estop_;
  bool enabled_ = false;
  bool sync_ = false;
  std::array<int, 2> levels_{};
};

}  // namespace piezo::hal::gpio
