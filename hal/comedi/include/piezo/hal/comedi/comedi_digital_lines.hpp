#pragma once
/// @file
/// The rig's digital lines on a DAQ card's digital I/O: amplifier enable
/// and sync on a digital output (or DIO) subdevice, set together by one
/// call; the e-stop on a digital input (or DIO) channel. Polarity, the
/// e-stop's latch and its watcher are the same logic as on GPIO
/// (gpio::GpioDigitalLines). Comedi reports no edges on digital inputs: the
/// input is read every kPollNs, so a press is seen within that (one held
/// shorter may be missed: an e-stop button is held).

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "piezo/hal/comedi/comedi_device.hpp"
#include "piezo/hal/digital_lines.hpp"
#include "piezo/hal/gpio/gpio_digital_lines.hpp"
#include "piezo/hal/line_group.hpp"

namespace piezo::hal::comedi {

struct DigitalLinesSettings {
  std::string device = "/dev/comedi0";
  int subdevice = -1;  ///< the outputs'; -1: the card's first digital output (DO or DIO)
  int enable_channel = 0;
  int sync_channel = -1;     ///< -1: not wired
  int estop_subdevice = -1;  ///< -1: the card's first digital input (DI or DIO)
  int estop_channel = -1;    ///< -1: not wired
  /// Each axis's trigger output on the outputs' subdevice, in the board's
  /// order (-1 or absent: none).
  std::vector<int> trigger_channels;
  gpio::GpioLinesSettings lines;
  bool trigger_active_low = false;
};

/// Output channels of one subdevice (below 32), set together by one
/// comedi_dio_bitfield2 call. Configured as outputs (on a DIO subdevice)
/// and written at `initial_levels` on construction.
class ComediOutputs final : public OutputLineGroup {
 public:
  ComediOutputs(const std::string& device, unsigned subdevice, std::vector<unsigned> channels,
                const std::vector<int>& initial_levels);

  Status set_levels(std::span<const int> levels) override;
  [[nodiscard]] std::size_t size() const override { return channels_.size(); }

 private:
  ComediDevice device_;
  unsigned subdevice_;
  std::vector<unsigned> channels_;
  unsigned mask_ = 0;
};

/// One input channel, read every kPollNs by its watcher; an edge is a
/// change of level between two reads.
class ComediPolledInput final : public InputLine {
 public:
  static constexpr std::int64_t kPollNs = 1'000'000;

  ComediPolledInput(const std::string& device, unsigned subdevice, unsigned channel);

  Status level(int& level) override;
  Status take_edges(int& count) override;
  Status wait_for_edge(std::int64_t timeout_ns, bool& ready) override;

 private:
  /// Reads the level and counts a change since the last read (any thread).
  Status sample(int& level);

  ComediDevice device_;
  unsigned subdevice_;
  unsigned channel_;
  std::atomic<int> last_level_{-1};
  std::atomic<int> edges_{0};
};

/// The lines a [lines.comedi] section names, checked against the card
/// (throws config::ConfigError naming the key); the outputs start idle.
[[nodiscard]] std::unique_ptr<DigitalLines> open_digital_lines(const DigitalLinesSettings& s);

}  // namespace piezo::hal::comedi
