#pragma once
/// @file
/// The rig's GPIO devices on a libgpiod chip, each owning the lines it
/// requests: the parallel DAC (data lines and strobe) and the digital lines
/// (amplifier enable, sync, e-stop). Lines are requested at their safe
/// levels (code 0, amplifier disabled), never for a moment elsewhere.

#include <memory>
#include <string>
#include <vector>

#include "piezo/hal/digital_lines.hpp"
#include "piezo/hal/drive.hpp"
#include "piezo/hal/gpio/gpio_digital_lines.hpp"
#include "piezo/hal/gpio/parallel_dac.hpp"
#include "piezo/hal/gpiod/gpiod_lines.hpp"

namespace piezo::hal::gpiod {

/// A parallel DAC on GPIO lines: where its lines are.
struct GpiodDacSettings {
  std::string chip = "gpiochip0";
  std::vector<int> data_offsets;  ///< least significant bit first
  int strobe_offset = -1;         ///< -1: no strobe line
  gpio::ParallelDacSettings dac;
};

struct GpiodLinesSettings {
  std::string chip = "gpiochip0";
  int enable_offset = -1;
  int sync_offset = -1;   ///< -1: not wired
  int estop_offset = -1;  ///< -1: not wired
  /// Each axis's trigger line, in the board's order (-1 or absent: none).
  std::vector<int> trigger_offsets;
  gpio::GpioLinesSettings gpio;
  gpio::GpioTriggerLines triggers;  ///< the axes of trigger_offsets that have one
};

class GpiodParallelDac final : public Drive {
 public:
  GpiodParallelDac(const GpiodDacSettings& settings, const std::string& consumer);

  Status write(double volts) override { return dac_.write(volts); }
  [[nodiscard]] double acknowledged_V() const override { return dac_.acknowledged_V(); }
  [[nodiscard]] DriveLimits limits() const override { return dac_.limits(); }

 private:
  GpiodOutputs lines_;
  gpio::ParallelDac dac_;
};

/// The digital lines on the chip, requested at their idle levels (the
/// amplifier disabled); the e-stop latches until released and reset.
[[nodiscard]] std::unique_ptr<DigitalLines> open_rig_lines(const GpiodLinesSettings& settings,
                                                           const std::string& consumer);

}  // namespace piezo::hal::gpiod
