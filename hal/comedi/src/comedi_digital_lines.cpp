#include "piezo/hal/comedi/comedi_digital_lines.hpp"

#include <fmt/format.h>

#include <chrono>
#include <stdexcept>
#include <thread>

#include "piezo/config/config_error.hpp"
#include "piezo/hal/gpio/owned_digital_lines.hpp"

namespace piezo::hal::comedi {
namespace {

constexpr SubdeviceKind kDigitalOutput{COMEDI_SUBD_DO, 0, "a digital output", COMEDI_SUBD_DIO};
constexpr SubdeviceKind kDigitalInput{COMEDI_SUBD_DI, 0, "a digital input", COMEDI_SUBD_DIO};

/// A DIO channel's direction; other subdevices have theirs fixed.
void set_direction(const ComediDevice& card, unsigned subdevice, unsigned channel,
                   unsigned direction) {
  if (comedi_get_subdevice_type(card.get(), subdevice) != COMEDI_SUBD_DIO) return;
  if (comedi_dio_config(card.get(), subdevice, channel, direction) < 0) {
    throw std::runtime_error(
        fmt::format("comedi {}: {}", card.path(), ComediDevice::last_error("comedi_dio_config")));
  }
}

/// The subdevice of `channel`, checked against the card; a refusal names
/// `subdevice_key` and `channel_key` of [lines.comedi].
unsigned checked(const std::string& device, int subdevice, int channel, const SubdeviceKind& kind,
                 const std::string& subdevice_key, const std::string& channel_key) {
  const ComediDevice card(device);
  const ChannelAddress address{
      .device = device, .subdevice = subdevice, .channel = channel, .range = 0};
  return card.checked_subdevice(address, kind, {"lines.comedi", subdevice_key, channel_key});
}

}  // namespace

ComediOutputs::ComediOutputs(const std::string& device, unsigned subdevice,
                             std::vector<unsigned> channels, const std::vector<int>& initial_levels)
    : device_(device), subdevice_(subdevice), channels_(std::move(channels)) {
  for (const unsigned c : channels_) {
    mask_ |= 1u << c;
    set_direction(device_, subdevice_, c, COMEDI_OUTPUT);
  }
  if (set_levels(initial_levels) != Status::ok) {
    throw std::runtime_error(fmt::format("comedi {}: {}", device_.path(),
                                         ComediDevice::last_error("comedi_dio_bitfield2")));
  }
}

Status ComediOutputs::set_levels(std::span<const int> levels) {
  unsigned bits = 0;
  for (std::size_t i = 0; i < channels_.size(); ++i) {
    if (levels[i] != 0) bits |= 1u << channels_[i];
  }
  return comedi_dio_bitfield2(device_.get(), subdevice_, mask_, &bits, 0) < 0 ? Status::io_error
                                                                              : Status::ok;
}

ComediPolledInput::ComediPolledInput(const std::string& device, unsigned subdevice,
                                     unsigned channel)
    : device_(device), subdevice_(subdevice), channel_(channel) {
  set_direction(device_, subdevice_, channel_, COMEDI_INPUT);
  int first = 0;
  if (sample(first) != Status::ok) {
    throw std::runtime_error(
        fmt::format("comedi {}: {}", device_.path(), ComediDevice::last_error("comedi_dio_read")));
  }
}

Status ComediPolledInput::sample(int& level) {
  unsigned bit = 0;
  if (comedi_dio_read(device_.get(), subdevice_, channel_, &bit) < 0) return Status::io_error;
  level = bit != 0 ? 1 : 0;
  const int before = last_level_.exchange(level);
  if (before >= 0 && before != level) edges_.fetch_add(1);
  return Status::ok;
}

Status ComediPolledInput::level(int& level) {
  return sample(level);
}

Status ComediPolledInput::take_edges(int& count) {
  int level = 0;
  const Status read = sample(level);
  count = edges_.exchange(0);
  return read;
}

Status ComediPolledInput::wait_for_edge(std::int64_t timeout_ns, bool& ready) {
  ready = false;
  for (std::int64_t waited = 0; waited < timeout_ns; waited += kPollNs) {
    int level = 0;
    if (const Status s = sample(level); s != Status::ok) return s;
    if (edges_.load() > 0) {
      ready = true;
      return Status::ok;
    }
    std::this_thread::sleep_for(std::chrono::nanoseconds(kPollNs));
  }
  return Status::ok;
}

std::unique_ptr<DigitalLines> open_digital_lines(const DigitalLinesSettings& s) {
  const unsigned out = checked(s.device, s.subdevice, s.enable_channel, kDigitalOutput, "subdevice",
                               "enable_channel");
  std::vector<unsigned> channels{static_cast<unsigned>(s.enable_channel)};
  if (s.sync_channel >= 0) {
    (void)checked(s.device, static_cast<int>(out), s.sync_channel, kDigitalOutput, "subdevice",
                  "sync_channel");
    channels.push_back(static_cast<unsigned>(s.sync_channel));
  }
  gpio::GpioLinesSettings lines = s.lines;
  lines.has_sync = s.sync_channel >= 0;
  gpio::GpioTriggerLines triggers{{}, s.trigger_active_low};
  for (std::size_t axis = 0; axis < s.trigger_channels.size(); ++axis) {
    const int channel = s.trigger_channels[axis];
    if (channel < 0) continue;
    (void)checked(s.device, static_cast<int>(out), channel, kDigitalOutput, "subdevice",
                  "trigger_channels");
    for (const unsigned c : channels) {
      if (c == static_cast<unsigned>(channel)) {
        throw config::ConfigError(
            s.device, "lines.comedi.trigger_channels",
            fmt::format("{} is an output here already; allowed: another channel", c));
      }
    }
    channels.push_back(static_cast<unsigned>(channel));
    triggers.axes.push_back(axis);
  }
  std::unique_ptr<InputLine> estop;
  if (s.estop_channel >= 0) {
    const unsigned in = checked(s.device, s.estop_subdevice, s.estop_channel, kDigitalInput,
                                "estop_subdevice", "estop_channel");
    if (in == out) {
      for (const unsigned c : channels) {
        if (c == static_cast<unsigned>(s.estop_channel)) {
          throw config::ConfigError(
              s.device, "lines.comedi.estop_channel",
              fmt::format("{} is an output here already; allowed: another channel", c));
        }
      }
    }
    estop =
        std::make_unique<ComediPolledInput>(s.device, in, static_cast<unsigned>(s.estop_channel));
  }
  return std::make_unique<gpio::OwnedDigitalLines>(
      lines,
      std::make_unique<ComediOutputs>(s.device, out, std::move(channels),
                                      gpio::GpioDigitalLines::idle_levels(lines, triggers)),
      std::move(estop), triggers);
}

}  // namespace piezo::hal::comedi
