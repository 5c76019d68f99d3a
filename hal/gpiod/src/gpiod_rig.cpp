#include "piezo/hal/gpiod/gpiod_rig.hpp"

#include "piezo/hal/gpio/owned_digital_lines.hpp"

namespace piezo::hal::gpiod {
namespace {

std::vector<unsigned> dac_offsets(const GpiodDacSettings& s) {
  std::vector<unsigned> out(s.data_offsets.begin(), s.data_offsets.end());
  if (s.strobe_offset >= 0) out.push_back(static_cast<unsigned>(s.strobe_offset));
  return out;
}

std::vector<unsigned> output_offsets(const GpiodLinesSettings& s) {
  std::vector<unsigned> out{static_cast<unsigned>(s.enable_offset)};
  if (s.sync_offset >= 0) out.push_back(static_cast<unsigned>(s.sync_offset));
  for (const std::size_t axis : s.triggers.axes) {
    out.push_back(static_cast<unsigned>(s.trigger_offsets[axis]));
  }
  return out;
}

std::unique_ptr<GpiodEdgeInput> estop_input(const GpiodLinesSettings& s,
                                            const std::string& consumer) {
  if (s.estop_offset < 0) return nullptr;
  return std::make_unique<GpiodEdgeInput>(s.chip, static_cast<unsigned>(s.estop_offset), consumer);
}

}  // namespace

GpiodParallelDac::GpiodParallelDac(const GpiodDacSettings& settings, const std::string& consumer)
    : lines_(settings.chip, dac_offsets(settings), gpio::ParallelDac::idle_levels(settings.dac),
             consumer),
      dac_(settings.dac, lines_) {}

std::unique_ptr<DigitalLines> open_rig_lines(const GpiodLinesSettings& settings,
                                             const std::string& consumer) {
  return std::make_unique<gpio::OwnedDigitalLines>(
      settings.gpio,
      std::make_unique<GpiodOutputs>(
          settings.chip, output_offsets(settings),
          gpio::GpioDigitalLines::idle_levels(settings.gpio, settings.triggers), consumer),
      estop_input(settings, consumer), settings.triggers);
}

}  // namespace piezo::hal::gpiod
