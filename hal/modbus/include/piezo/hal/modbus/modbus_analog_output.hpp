#pragma once
/// @file
/// The drive through a Modbus analog-output module (a remote I/O module's
/// holding register) feeding the piezo amplifier's input.
///
/// Such a module holds its last value when the link dies: nothing the
/// firmware does can then reach it. The module's own communication watchdog
/// is what brings it to 0 V; its registers are written here at start.

#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "piezo/hal/drive.hpp"
#include "piezo/hal/modbus/link.hpp"

namespace piezo::hal::modbus {

struct AnalogOutputSettings {
  int unit_id = 1;
  int address = 0;               ///< holding register of the output channel
  double counts_per_V = 1000.0;  ///< register counts per volt at the module's output
  double full_scale_V = 10.0;    ///< the module's highest output [V]
  double amplifier_gain = 20.0;  ///< amplifier output volts per input volt
  /// Holding registers written once at start, in order, to arm the module's
  /// communication watchdog (register, value), e.g. a WAGO 750-352's
  /// timeout and function-code mask. Empty: no watchdog.
  std::vector<std::pair<int, int>> watchdog_writes;
};

/// The register value for amplifier output `volts`, clamped to the
/// register's range (a value past it must never wrap to a small one).
[[nodiscard]] std::uint16_t counts_for(const AnalogOutputSettings& settings, double volts);

class ModbusAnalogOutput final : public Drive {
 public:
  /// The largest register value: counts_per_V * full_scale_V must not exceed it.
  static constexpr double kMaxCounts = 65535.0;

  /// Connects, writes 0 V, then arms the watchdog; throws std::runtime_error
  /// naming the register when a write is refused, std::invalid_argument
  /// when full scale does not fit the register.
  ModbusAnalogOutput(const LinkSettings& link, const AnalogOutputSettings& settings);

  /// Writes the register for amplifier output `volts`: one round trip.
  Status write(double volts) override;
  [[nodiscard]] double acknowledged_V() const override { return acknowledged_V_; }
  [[nodiscard]] DriveLimits limits() const override;

 private:
  Link link_;
  AnalogOutputSettings settings_;
  double acknowledged_V_ = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace piezo::hal::modbus
