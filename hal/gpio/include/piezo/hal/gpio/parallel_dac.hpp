#pragma once
/// @file
/// A parallel-input DAC driven through digital lines: the code goes out on
/// N data lines in one bulk write, then an optional WR/latch strobe pulses
/// so that the DAC takes all bits at once. Bit order and polarity are
/// configuration; the amplifier behind the DAC multiplies by its gain.

#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include "piezo/hal/drive.hpp"
#include "piezo/hal/line_group.hpp"

namespace piezo::hal::gpio {

struct ParallelDacSettings {
  int bits = 12;                  ///< data lines, the first carrying the least significant bit
  bool has_strobe = true;         ///< a WR/latch line after the data lines
  bool data_active_low = false;   ///< a logical 1 is a low level
  bool strobe_active_low = true;  ///< WR is usually active low: latch on the rising edge
  double full_scale_V = 5.0;      ///< DAC output at the highest code
  double amplifier_gain = 20.0;
};

class ParallelDac final : public Drive {
 public:
  static constexpr int kMaxLines = 33;  // 32 data bits and the strobe

  /// The physical levels of the data lines (code 0, for 0 V) and the strobe
  /// (idle): what the lines must be requested at.
  [[nodiscard]] static std::vector<int> idle_levels(const ParallelDacSettings& settings);

  /// `lines` holds the data lines in bit order (LSB first), then the strobe if any.
  ParallelDac(const ParallelDacSettings& settings, OutputLineGroup& lines);

  Status write(double volts) override;
  [[nodiscard]] double acknowledged_V() const override { return acknowledged_V_; }
  [[nodiscard]] DriveLimits limits() const override;

  /// The code for amplifier output `volts` (clamped to the DAC's range).
  [[nodiscard]] std::uint32_t code_for(double volts) const;

 private:
  Status put(std::uint32_t code, bool strobe_asserted);

  ParallelDacSettings settings_;
  OutputLineGroup& lines_;
  std::uint32_t max_code_;
  std::array<int, kMaxLines> levels_{};
  double acknowledged_V_ = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace piezo::hal::gpio
