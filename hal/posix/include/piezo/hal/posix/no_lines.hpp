#pragma once
/// @file
/// Digital lines for a rig that has none wired (an amplifier without an
/// enable input, no e-stop line, no scope sync): every call succeeds and
/// the e-stop is never pressed. The Modbus HIL set-up uses it.

#include "piezo/hal/digital_lines.hpp"

namespace piezo::hal::posix {

class NoLines final : public DigitalLines {
 public:
  Status set_amplifier_enable(bool) override { return Status::ok; }
  Status set_sync(bool) override { return Status::ok; }
  [[nodiscard]] EstopState poll_estop() override { return {}; }
};

}  // namespace piezo::hal::posix
