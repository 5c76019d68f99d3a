#pragma once
/// @file
/// The rig's digital lines: amplifier enable (out), a sync pulse per drive
/// period (out) for a scope or DAQ, the emergency stop (in, with edge
/// events), and per axis a trigger (out) that a scan pulses at measured
/// angles (position compare) for a detector.

#include <cstddef>

#include "piezo/hal/status.hpp"

namespace piezo::hal {

/// E-stop as seen by one poll: whether it is pressed now and whether any
/// edge arrived since the last poll (a press released again still counts).
struct EstopState {
  bool pressed = false;
  bool edge_seen = false;
  Status status = Status::ok;
};

class DigitalLines {
 public:
  DigitalLines() = default;
  DigitalLines(const DigitalLines&) = delete;
  DigitalLines& operator=(const DigitalLines&) = delete;
  virtual ~DigitalLines() = default;

  /// Logical levels (true = asserted); polarity is the backend's business.
  virtual Status set_amplifier_enable(bool enabled) = 0;
  virtual Status set_sync(bool high) = 0;
  /// Non-blocking: drains pending edge events. Called every drive cycle.
  [[nodiscard]] virtual EstopState poll_estop() = 0;
  /// Drops the amplifier enable now, from any thread: the protocol's e-stop
  /// acts through it while the drive loop may be blocked in a slow drive
  /// write. It holds until the next set_amplifier_enable(true) (the next
  /// run's start). False where there is no line to drop (the drive loop's
  /// own stop, after the write in progress, is then the only path).
  virtual bool trip() { return false; }
  /// A hardware e-stop latches: the enable stays down after the button is
  /// released, until the operator resets the fault. Clears that latch once
  /// the button is released; false (and the latch kept) while it is still
  /// pressed or its line cannot be read. Not called during a run.
  [[nodiscard]] virtual bool reset_estop() { return true; }
  /// Whether the board's axis `axis` has a trigger line wired.
  [[nodiscard]] virtual bool has_trigger(std::size_t /*axis*/) const { return false; }
  /// Sets axis `axis`'s trigger line (true = asserted). Real-time safe;
  /// io_error where none is wired.
  virtual Status set_trigger(std::size_t /*axis*/, bool /*high*/) { return Status::io_error; }
};

}  // namespace piezo::hal
