#pragma once
/// @file
/// The drive: the voltage at the piezo amplifier's output, through whatever
/// DAC or analog-output module the rig has.

#include "piezo/hal/status.hpp"

namespace piezo::hal {

/// What the drive hardware can produce, in amplifier output volts.
struct DriveLimits {
  double V_min = 0.0;
  double V_max = 0.0;
};

class Drive {
 public:
  Drive() = default;
  Drive(const Drive&) = delete;
  Drive& operator=(const Drive&) = delete;
  virtual ~Drive() = default;

  /// Commands the amplifier output voltage [V]. Called every drive cycle: must be fast.
  virtual Status write(double volts) = 0;
  /// Ends a tick of the drive loop: every axis has written its value. A
  /// device that takes every axis's value at once (a scan of one card's
  /// channels) sends them here, with the status of that; others are done.
  virtual Status end_tick() { return Status::ok; }
  /// Puts `volts` out at once, ahead of anything the drive queued: a stop's
  /// 0 V. A drive without a queue writes as usual.
  virtual Status write_now(double volts) { return write(volts); }
  /// The output the device last acknowledged taking [V] (a write that
  /// returned ok); NaN before the first. What a stop reports when it cannot
  /// confirm 0 V: never the command, only what the device confirmed.
  [[nodiscard]] virtual double acknowledged_V() const = 0;
  /// Whether an ok write_now() means an input wired to the output measured
  /// the value (true), or only that the device took the write (false).
  [[nodiscard]] virtual bool reads_back() const { return false; }
  /// The range the hardware can produce; the firmware clamps to it.
  [[nodiscard]] virtual DriveLimits limits() const = 0;
  /// Time from a write to the output starting to change [s]: a DAC latched
  /// on its own clock adds up to one update period. Models replaying a log
  /// shift the drive by it.
  [[nodiscard]] virtual double output_latency_s() const { return 0.0; }
};

}  // namespace piezo::hal
